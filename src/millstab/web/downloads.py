"""Tab "Downloads": every table (CSV/JSON), figure (PNG/SVG, the CLI's matplotlib figures from the
``*_figure`` functions) and the config TOML that reproduces the session from the command line. The files
are made when clicked, from the session's current results; the CSVs are the CLI's (``csv_text``)."""

from __future__ import annotations

import io
import json

import panel as pn

from millstab import api
from millstab.io.results import csv_text, to_jsonable
from millstab.web.common import esc
from millstab.web.state import Session


def _figure_bytes(make, fmt: str) -> io.BytesIO:
    from millstab.io.figures import figure_bytes

    return io.BytesIO(figure_bytes(make(), fmt))


def _text_bytes(text: str) -> io.BytesIO:
    return io.BytesIO(text.encode("utf-8"))


def _json_bytes(doc) -> io.BytesIO:
    return _text_bytes(json.dumps(to_jsonable(doc), indent=2) + "\n")


class DownloadsTab:
    def __init__(self, session: Session):
        self.s = session
        self.note = pn.pane.HTML("", css_classes=["downloads-note"])
        self.buttons = []
        for label, filename, available, make in self.items():
            stem = filename.replace(".", "-")
            text = label if filename == "config.toml" else f"{label}: {filename}"  # the config's file is named after it
            button = pn.widgets.FileDownload(callback=make, filename=filename, label=text,
                                             width=440, css_classes=[f"dl-{stem}"], visible=False)
            self.buttons.append((available, button))
        self.config_button = self.buttons[0][1]
        self.box = pn.Column(*(b for _, b in self.buttons))
        session.param.watch(lambda e: self.refresh(),
                            ["cfg", "lobes", "fit", "plan", "post", "pmap", "rec", "points", "cuts"])
        self.refresh()

    def items(self) -> list[tuple[str, str, object, object]]:
        """(label, file name, available() → bool, make() → BytesIO) of every file the page offers; ``make``
        reads the session's results when clicked."""
        s = self.s
        lobes = lambda fmt: _figure_bytes(lambda: api.lobes_figure(s.lobes, s.points, s.raw), fmt)  # noqa: E731
        fit = lambda fmt: _figure_bytes(lambda: api.fit_figure(s.fit, api.modal(s.fit_cfg)[0], s.points,  # noqa: E731
                                                               method=s.fit.method), fmt)
        # the figure of `millstab map --plot`: the posterior moved to the map's condition (its cuts, prior SLD, title)
        pmap = lambda fmt: _figure_bytes(lambda: api.map_figure(  # noqa: E731
            s.map_post if s.map_post is not None else s.post, *s.pmap), fmt)
        has_fit = lambda: s.fit is not None and s.points is not None  # noqa: E731
        has_map = lambda: s.pmap is not None and s.post is not None  # noqa: E731
        return [
            ("config TOML (millstab lobes FILE)", "config.toml",
             lambda: s.cfg is not None and s.cfg.structure.is_modal, lambda: _text_bytes(api.config_toml(s.cfg))),
            ("SLD table CSV (= millstab lobes --out)", "lobes.csv", lambda: s.lobes is not None,
             lambda: _text_bytes(s.lobes.csv())),
            ("SLD figure PNG", "lobes.png", lambda: s.lobes is not None, lambda: lobes("png")),
            ("SLD figure SVG", "lobes.svg", lambda: s.lobes is not None, lambda: lobes("svg")),
            ("identification JSON (= millstab identify --out)", "fit.json", has_fit,
             lambda: _json_bytes(s.fit.to_json())),
            ("fitted SLD figure PNG", "fit.png", has_fit, lambda: fit("png")),
            ("fitted SLD figure SVG", "fit.svg", has_fit, lambda: fit("svg")),
            ("planned tests CSV (= millstab design --out)", "plan.csv", lambda: s.plan is not None,
             lambda: _text_bytes(csv_text(*s.plan.table()))),
            ("planned tests figure PNG", "plan.png", lambda: s.plan is not None,
             lambda: _figure_bytes(lambda: api.design_figure(s.plan, s.cfg, s.points), "png")),
            ("posterior JSON (= millstab update --out)", "posterior.json", lambda: s.post is not None,
             lambda: _json_bytes(s.post.to_json())),
            ("posterior pair plot PNG", "posterior.png", lambda: s.post is not None,
             lambda: _figure_bytes(lambda: api.corner_figure(s.post), "png")),
            ("P(stable) map CSV (= millstab map --out)", "map.csv", has_map,
             lambda: _text_bytes(csv_text(*api.map_table(*s.pmap)))),
            ("P(stable) map PNG", "map.png", has_map, lambda: pmap("png")),
            ("P(stable) map SVG", "map.svg", has_map, lambda: pmap("svg")),
            ("recommendation JSON (= millstab recommend --out)", "recommendation.json", lambda: s.rec is not None,
             lambda: _json_bytes(s.rec.to_json())),
        ]

    def refresh(self) -> None:
        """Show the buttons of what the session holds; only a change of availability touches the page."""
        for (available, button) in self.buttons:
            ok = bool(available())
            if button.visible != ok:
                button.visible = ok
        name = (self.s.cfg.name if self.s.cfg is not None else "") or "config"
        if self.config_button.filename != f"{name}.toml":
            self.config_button.filename = f"{name}.toml"
        note = ('<span class="ms-note">a measured-FRF structure has no config TOML of its own: reference the FRF '
                'files in a [structure.frf] table</span>'
                if self.s.cfg is not None and not self.s.cfg.structure.is_modal
                else "")
        if self.note.object != note:
            self.note.object = note

    def view(self):
        return pn.Column(pn.pane.HTML(f"<b>{esc('Files of this session')}</b> (made when clicked)"), self.note,
                         self.box, name="Downloads")
