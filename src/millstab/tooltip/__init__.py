"""The tool tip of any tool at any stickout, by receptance coupling (RCSA): the tool a Timoshenko beam
(:mod:`.beam`), the spindle–holder at its face (:mod:`.holder`: rigid, face modes, measured, or from an
artifact test / finite differences), coupled by :mod:`.rcsa`; :mod:`.tool` builds the tip FRF as a
:class:`~millstab.model.Structure`. Model layer: no file I/O. See docs/tooltip.md.
"""

from millstab.tooltip.beam import MATERIALS, Beam, Material, Section, material
from millstab.tooltip.holder import (FaceMode, MeasuredHolder, ModalHolder, RigidHolder, XYHolder, artifact_beam,
                                     from_artifact, from_finite_differences)
from millstab.tooltip.rcsa import couple, decouple_artifact
from millstab.tooltip.tool import DEFAULT_FLUTE_RATIO, Tool, peaks, tip_band, tip_grid, tip_receptance, tip_structure

__all__ = ["DEFAULT_FLUTE_RATIO", "FaceMode", "MATERIALS", "Beam", "Material", "MeasuredHolder", "ModalHolder",
           "RigidHolder", "Section", "Tool", "XYHolder", "artifact_beam", "couple", "decouple_artifact",
           "from_artifact", "from_finite_differences", "material", "peaks", "tip_band", "tip_grid", "tip_receptance",
           "tip_structure"]
