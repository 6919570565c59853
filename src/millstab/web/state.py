"""The state of one browser session: what the user loaded and computed, and a private temporary folder.

``pn.serve`` calls the page function once per browser tab, so every tab builds its own
:class:`Session`: two tabs never see each other's inputs or results. The folder holds uploaded FRF files
(the readers take paths) and nothing else; it is removed when the session ends, or at interpreter exit.
A config from text (an upload) may name only these files (:attr:`Session.uploads`): never another path
on the server.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
import weakref
from pathlib import Path

import param

_LIVE: "weakref.WeakSet[Session]" = weakref.WeakSet()


class Session(param.Parameterized):
    """One tab's data. Tabs watch the parameters to redraw; results are set by the jobs that made them."""

    cfg = param.Parameter(default=None, doc="the current valid Config (millstab.config.Config) or None")
    points = param.Parameter(default=None, doc="uploaded boundary points (PointSet) or None")
    fit = param.Parameter(default=None, doc="the last identification (millstab.identify.result.Fit) or None")
    fit_cfg = param.Parameter(default=None, doc="the config the fit was made from")
    plan = param.Parameter(default=None, doc="planned next test speeds (SpeedDesign) or None")
    cuts = param.Parameter(default=None, doc="uploaded labelled test cuts (PointSet) or None")
    post = param.Parameter(default=None, doc="the posterior of the last update or None")
    pmap = param.Parameter(default=None, doc="(rpm, depth_mm, P(stable)) of the last map or None")
    map_post = param.Parameter(default=None, doc="the posterior the last map is for: post moved to the map's "
                                                 "condition (api.for_condition), or None")
    rec = param.Parameter(default=None, doc="the last recommendation or None")
    lobes = param.Parameter(default=None, doc="the last SLD (millstab.api.Lobes) or None")
    raw = param.Boolean(default=False, doc="the raw lobes are drawn")
    origin = param.String(default="", doc="what cfg was made from, as the result panes say it "
                                          "(\"uploaded my_tool.toml\", "
                                          "\"the packaged example ex3 — no config loaded\")")

    def __init__(self, **params):
        super().__init__(**params)
        self.folder = Path(tempfile.mkdtemp(prefix="millstab-app-"))
        #: FRF files uploaded in this session: {file name as uploaded: saved path}, the only files a
        #: config from text may name; and {saved file name: saved path}, what the form's FRF terms name
        self.uploads: dict[str, Path] = {}
        self.saved: dict[str, Path] = {}
        _LIVE.add(self)

    def save_upload(self, role: str, name: str, content: bytes | str) -> Path:
        """Keep an uploaded FRF file in the session's folder (:func:`millstab.web.uploads.save_in`) and
        register it under its uploaded name."""
        from millstab.web.uploads import save_in

        path = save_in(self.folder, role, name, content)
        self.uploads[Path(name).name] = path
        self.saved[path.name] = path
        return path

    def close(self) -> None:
        """Remove the session's folder (uploaded files)."""
        shutil.rmtree(self.folder, ignore_errors=True)


@atexit.register
def _close_all() -> None:
    for s in list(_LIVE):
        s.close()
