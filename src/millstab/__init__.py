"""millstab: milling chatter stability lobes, in-process modal identification and sensitivity.

Inside the package every quantity is SI (Hz for natural frequencies, N/m, N/m², rad, m); the
edges (configs, CLI, plots) speak rpm, mm, N/µm and MPa.
"""

from millstab.errors import InputError, UnitWarning
from millstab.model import Cutting, Mode, Structure

__all__ = ["Cutting", "InputError", "Mode", "Structure", "UnitWarning", "__version__"]
__version__ = "0.1.0"
