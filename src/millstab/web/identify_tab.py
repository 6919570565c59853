"""Tab "Identify": boundary points (upload or the packaged example), identification in a worker with
progress and cancel, the estimate ± σ table, the fitted SLD over the points, the fit's warnings, and the
speeds of the next tests (:func:`millstab.api.design`)."""

from __future__ import annotations

import numpy as np
import panel as pn

from millstab import api
from millstab.errors import InputError
from millstab.web.common import TextBox, computed_for, error_html, esc, form_value, html_table
from millstab.web.jobs import JobBar, collected
from millstab.web.plots import set_line, set_points, set_scatter, sld_figure
from millstab.web.state import Session
from millstab.web.uploads import MAX_TEXT_BYTES, POINTS_TYPES, dropper, latest


def points_upload(session: Session, attr: str, drop, error, note) -> None:
    """Parse the file in ``drop`` with the points file's validators into ``session.<attr>``; a problem
    goes to ``error`` and the previous points stay."""
    error.object = ""
    try:
        got = latest(drop, MAX_TEXT_BYTES, POINTS_TYPES, "points CSV")
        if got is None:
            return
        # the reader's notes (label columns, depth scale) reach the page, as a job's do
        pts, notes = collected(lambda _: api.points_from_text(got[1], got[0]), None)
    except InputError as exc:
        error.object = error_html(str(exc))
        return
    setattr(session, attr, pts)
    shown = "".join(f'<div class="ms-note">{esc(w)}</div>' for w in notes)
    note.object = f'<span class="ms-done">{esc(got[0])}: {len(pts)} points</span>{shown}'



#: the most next tests the page plans (the browser's bound before; the planner itself takes any number)
MAX_PLAN = 100


def _n_tests(value) -> int:
    """The form's number of next tests: a whole number 1..MAX_PLAN."""
    if not (float(value).is_integer() and 1 <= value <= MAX_PLAN):
        raise InputError("next tests", value, f"a whole number of test speeds, 1 to {MAX_PLAN}")
    return int(value)

class IdentifyTab:
    def __init__(self, session: Session):
        self.s = session
        self.drop = dropper("boundary points CSV", POINTS_TYPES, css="drop-points")
        self.drop_error = pn.pane.HTML("", css_classes=["e-points-upload"])
        self.points_note = pn.pane.HTML("", css_classes=["points-note"])
        self.format = pn.pane.HTML('<span class="ms-note">columns rpm,depth_mm[,label][,weight][,chatter_hz]; '
                                   'boundary points have no label</span>', width=330)
        self.example = pn.widgets.Button(label=f"Use example:{api.list_example_points()[0]}", width=200,
                                         css_classes=["example-points"])
        self.method = pn.widgets.Select(label="method", options=list(api.IDENTIFY_METHODS), value="lsq", width=100)
        self.free = pn.widgets.TextInput(label="free parameters (blank = all)", value="", width=220,
                                         placeholder="e.g. fn_x,k_x,zeta_x")
        self.axisym = pn.widgets.Checkbox(label="x = y (axisymmetric)", value=False)
        self.seed = pn.widgets.IntInput(label="seed", value=0, width=80)
        self.job = JobBar("Identify", "identify")
        self.table = TextBox("fit-table", width=None, height=None)
        self.warnings = TextBox("fit-warnings", width=700, height=None)
        self.fig, self.src = sld_figure("identified SLD over the points", name="fit", limit="identified",
                                       second="start", raw=False)
        # no start/end in the browser (common.form_value): the server checks what is typed
        self.n_plan = pn.widgets.IntInput(label="next tests", value=8, width=90)
        self.plan_job = JobBar("Plan next tests", "plan")
        self.plan_table = TextBox("plan-table", width=None, height=None)
        self.drop.param.watch(lambda e: points_upload(session, "points", self.drop, self.drop_error, self.points_note),
                              "value")
        self.example.on_click(lambda e: self.use_example())
        self.job.run.on_click(lambda e: self.run())
        self.plan_job.run.on_click(lambda e: self.plan())
        session.param.watch(lambda e: set_points(self.src, e.new), "points")

    def use_example(self) -> None:
        name = api.list_example_points()[0]
        self.s.points = api.points(f"example:{name}")
        self.drop_error.object = ""
        self.points_note.object = f'<span class="ms-done">example:{name}: {len(self.s.points)} points</span>'

    def run(self) -> None:
        cfg, pts = self.s.cfg, self.s.points
        if cfg is None or pts is None:
            self.job.status.text = error_html("need a valid config (Tool and cut) and boundary points")
            return
        seed, bad = form_value(self.seed, "seed", lambda v: api.check_seed(v, "seed"), "a whole number, e.g. 0")
        if bad:
            self.job.status.text = error_html(bad)
            return
        opts = dict(method=self.method.value, free=self.free.value.strip() or None, axisymmetric=self.axisym.value,
                    seed=seed)
        origin = self.s.origin
        self.job.start(lambda progress: (api.identify(cfg, pts, progress=progress, **opts), cfg, pts, opts["method"],
                                         origin), self.show)

    def show(self, result, caught) -> None:
        fit, cfg, pts, method, origin = result
        self.s.fit, self.s.fit_cfg = fit, cfg
        se = fit.std_errors if fit.std_errors is not None else np.full(len(fit.names), np.nan)
        rows = [(n, f"{v:.6g}", f"{e:.3g}" if np.isfinite(e) else "–", u, f"{s:.6g}")
                for n, v, e, u, s in zip(fit.names, fit.estimate, se, fit.units, fit.start)]
        self.table.text = (computed_for(origin)
                           + html_table(("parameter", "estimate", "± σ", "unit", "start"), rows, "fit")
                           + f'<div class="ms-note">{esc(method)}: MLAE {fit.mlae:.4g} mm, {fit.iterations} '
                             f'iterations, {fit.evaluations} evaluations, {fit.time_s:.2f} s, {fit.n_points} '
                             'points</div>')
        lines = list(fit.warnings) + [w for w in caught if w not in fit.warnings]
        self.warnings.text = ("<b>warnings</b><ul>" + "".join(f"<li>{esc(w)}</li>" for w in lines) + "</ul>"
                                if lines else '<span class="ms-note">no warnings</span>')
        rpm = api.fit_rpm(pts)
        curves = api.fit_curves(fit, api.modal(cfg)[0], rpm)
        nan = np.full(rpm.size, np.nan)
        set_line(self.src["env"], rpm, curves[1], lobe=nan, chatter_hz=nan)
        set_line(self.src["other"], rpm, curves[0])
        set_points(self.src, pts)
        set_scatter(self.src, "plan", [], [])

    def plan(self) -> None:
        cfg, pts, fit = self.s.cfg, self.s.points, self.s.fit
        if cfg is None:
            self.plan_job.status.text = error_html("need a valid config (Tool and cut)")
            return
        if fit is not None and self.s.fit_cfg is not cfg:
            fit = None  # the form changed since the fit: plan around the form's structure
        n, bad = form_value(self.n_plan, "next tests", _n_tests, f"a whole number of test speeds, 1 to {MAX_PLAN}")
        if bad:
            self.plan_job.status.text = error_html(bad)
            return
        doc = None if fit is None else fit.to_json()
        origin = self.s.origin
        self.plan_job.start(lambda progress: (api.design(cfg, n=n, points=pts, fit=doc), origin), self.show_plan)

    def show_plan(self, result, caught) -> None:
        plan, origin = result
        self.s.plan = plan
        tests = plan.tests()
        rows = [(f"{r:.0f}", c, f"{d:.4g}") for r, c, d in tests]
        notes = "".join(f'<div class="ms-note">{esc(w)}</div>' for w in caught)
        self.plan_table.text = (computed_for(origin)
                                + html_table(("rpm", "tests", "predicted depth [mm]"), rows, "plan") + notes)
        set_scatter(self.src, "plan", [r for r, _, _ in tests], [d for _, _, d in tests])

    def view(self):
        inputs = pn.Card(pn.Row(pn.Column(self.drop, self.format, self.drop_error, self.points_note), self.example,
                                margin=(0, 0, 20, 0)),
                         pn.Row(self.method, self.free, self.seed, self.axisym), self.job,
                         title="Boundary points and identification", collapsible=False)
        plan = pn.Card(pn.Row(self.n_plan, self.plan_job), self.plan_table.view(), title="Next tests",
                       collapsible=False)
        return pn.Column(inputs, pn.Row(self.table.view(), self.warnings.view()),
                         pn.pane.Bokeh(self.fig, sizing_mode="stretch_width"), plan, name="Identify")
