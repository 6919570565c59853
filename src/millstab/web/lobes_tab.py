"""Tab "Lobes": the SLD of the current config (any registered engine), raw lobes, hover readout and the
uploaded points and cuts overlaid; redrawn on every valid edit of the form. The zero-order engine
(milliseconds) runs in the page's callback; the time-domain engines run in a worker with progress."""

from __future__ import annotations

import time
import traceback

import numpy as np
import panel as pn

from millstab import api
from millstab.errors import InputError
from millstab.web.common import computed_for, error_html, esc
from millstab.web.jobs import JobBar, collected
from millstab.web.common import TextBox
from millstab.web.plots import set_line, set_points, set_raw, sld_figure
from millstab.web.state import Session

class LobesTab:
    def __init__(self, session: Session):
        self.s = session
        self.fig, self.src = sld_figure(name="sld", second="")
        self.engine = pn.widgets.Select(label="engine", options=list(api.ENGINES), value="zoa", width=120,
                                        css_classes=["engine"])
        self.raw = pn.widgets.Checkbox(label="raw lobes (zoa)", value=False, css_classes=["raw-lobes"])
        self.summary = TextBox("lobes-summary", height=66)
        self.error = pn.pane.HTML("", css_classes=["lobes-error"])
        self.overlay_note = TextBox("lobes-overlay-note", height=None)  # the points and cuts not drawn, and why
        self.job = JobBar("Compute", "lobes")
        self.job_box = pn.Column(self.job, visible=False)
        self.job.run.on_click(lambda e: self.redraw(force=True))
        self.engine.param.watch(lambda e: self.redraw(), "value")
        self.raw.param.watch(lambda e: self.redraw(), "value")
        session.param.watch(lambda e: self.redraw(), "cfg")
        session.param.watch(lambda e: self.overlay(), ["points", "cuts", "cfg"])
        self.timing = 0.0
        self.redraw()

    def overlay(self) -> None:
        """Draw the boundary points and test cuts made in the form's condition; say how many others there are and
        their conditions (an edit of the form's condition made loaded cuts vanish from the SLD without a word,
        while the update still used them)."""
        cfg, notes = self.s.cfg, []
        points, note = api.points_drawn(self.s.points, cfg)
        if note:
            notes.append(f"boundary points (Identify): {note}")
        cuts, note = api.points_drawn(self.s.cuts, cfg)
        if note:
            notes.append(f"test cuts (Update and recommend): {note}; the update uses every cut, in its own condition")
        # the SLD is the form's condition: points made in others are not drawn on it
        set_points(self.src, api.overlay_points(points, cuts))
        self.overlay_note.text = "".join(f'<div class="ms-note">{esc(n)}</div>' for n in notes)

    def redraw(self, force: bool = False) -> None:
        cfg, origin = self.s.cfg, self.s.origin
        if cfg is None:
            return
        self.error.object = ""
        engine = self.engine.value
        try:
            rpm = api.speeds(None, cfg)
        except InputError as exc:
            self.error.object = error_html(str(exc))
            return
        if engine == api.cheapest_engine():  # fast enough to run in the page's own callback
            self.job_box.visible = False
            t0 = time.perf_counter()
            try:
                # as a job would: this session's notes (the zero-order model's validity), each once
                # without the spectral check (up to ~130 ms): a redraw per edit
                result, notes = collected(lambda _: api.lobes(cfg, rpm, engine=engine, check=False), None)
            except InputError as exc:
                self.error.object = error_html(str(exc))
                return
            except Exception as exc:  # a bug must not escape into the server's handler: show it, keep the page
                traceback.print_exc()
                self.error.object = error_html(f"failed: {type(exc).__name__}: {exc}")
                return
            self.timing = time.perf_counter() - t0
            self.show(result, notes, origin=origin)
            return
        self.job_box.visible = True
        if not force:
            self.clear()  # the SLD drawn was another config's or engine's: neither shown nor offered for download
            self.summary.text = (f'<span class="ms-note">{esc(engine)} takes seconds to minutes for '
                                   f'{rpm.size} speeds: press Compute</span>')
            return
        self.job.start(lambda progress: api.lobes(cfg, rpm, engine=engine, progress=progress),
                       self.shown_for(cfg, origin))

    def shown_for(self, cfg, origin: str):
        """The job's callback for an SLD of ``cfg``: shown only while ``cfg`` is still the session's config and the
        engine still the selected one (an edit during the job made it another config's: a stale SLD, which the
        Downloads tab would have offered beside the new config's TOML)."""
        engine = self.engine.value

        def show(result, caught):
            if self.s.cfg is cfg and self.engine.value == engine:
                self.show(result, caught, origin)
        return show

    def clear(self) -> None:
        """No SLD: the drawn lines emptied and the session's result dropped (Downloads then offers none)."""
        self.s.lobes = None
        for key in ("env", "preview"):
            if key in self.src:
                set_line(self.src[key], [], [], lobe=np.zeros(0, int), chatter_hz=np.zeros(0))
        set_raw(self.src["raw"], None)

    def show(self, result, caught=(), origin: str = "") -> None:
        self.s.lobes = result
        env = result.envelope
        for key in ("env", "preview"):
            if key in self.src:
                set_line(self.src[key], env.rpm, env.depth_mm, lobe=np.asarray(env.lobe),
                         chatter_hz=np.asarray(env.chatter_hz, float))
        self.s.raw = bool(self.raw.value)
        set_raw(self.src["raw"], api.raw_lobes(result.config, env.rpm) if self.raw.value else None, env.rpm,
                env.depth_mm)
        cfg = result.config
        title = f"{api.sld_title(cfg)} ({result.engine})"
        if self.fig.title.text != title:  # an unchanged property is not sent (every change re-lays the page out)
            with pn.io.unlocked():
                self.fig.title.text = title
        notes = "".join(f'<div class="ms-note">{esc(w)}</div>' for w in caught)
        shown = "<br>".join(esc(line) for line in result.summary().splitlines())
        self.summary.text = computed_for(origin) + shown + notes

    def view(self):
        return pn.Column(pn.Row(self.engine, self.raw, self.job_box), self.error, self.summary.view(),
                         self.overlay_note.view(),
                         pn.pane.Bokeh(self.fig, sizing_mode="stretch_width"),
                         pn.pane.HTML('<span class="ms-note">Hover the limit for speed, depth, chatter frequency and '
                                      'lobe number. Uploaded boundary points and test cuts are drawn by label.</span>'),
                         name="Lobes")
