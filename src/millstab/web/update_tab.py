"""Tab "Update and recommend": labelled test cuts (upload), the posterior of the modal parameters in a
worker with progress and cancel, the P(stable) map with its 5/50/95 % boundaries, the recommended cut at a
chosen risk and the next test cut (:mod:`millstab.api.update`)."""

from __future__ import annotations

import numpy as np
import panel as pn

from millstab import api
from millstab.errors import InputError
from millstab.web.common import TextBox, computed_for, error_html, esc, form_value, html_table
from millstab.web.identify_tab import points_upload
from millstab.web.jobs import JobBar
from millstab.web.plots import map_figure
from millstab.web.state import Session
from millstab.web.uploads import (MAX_FRF_BYTES, MAX_TEXT_BYTES, POINTS_TYPES, LimitedDropper, check_type, dropper,
                                  latest, save_in)

#: recordings of the cuts: WAV (a microphone) or CSV time_s,signal (an accelerometer), each at most this large
RECORDING_TYPES = (".wav", ".csv")
MAX_RECORDING_BYTES = MAX_FRF_BYTES
#: the recordings one session holds at once [bytes]: each is kept in the server's memory and its folder (a campaign's
#: tens of cuts of a few MB each fit; without a bound, file after file filled the server's memory and disk)
MAX_RECORDINGS_TOTAL_BYTES = 200_000_000

#: speeds of the P(stable) map (the map's cost is speeds × posterior samples)
MAP_SPEEDS = 240
#: speeds of the map and of the recommendation's coarse grid for a posterior of an engine other than the cheapest
#: (sdm at steps=10 took 3.2 ms CPU a sample and speed on the 2-core build machine: the 240-speed map of 100
#: samples 77 s CPU, the recommendation at its 200 coarse speeds over 5 min; 60 of each are ~4x less). Such a map
#: is made when asked (Map and recommend), not after every update.
MAP_SPEEDS_ACCURATE = 60
#: the map's depth axis reaches this factor above the deepest cut marked on it (the recommended cut, the next test)
MARK_HEADROOM = 1.1


def marked_depths(rec) -> list[float]:
    """The depths [mm] of the cuts a map marks for ``rec``: the recommended cut, and its next test when that is in
    the map's condition (:func:`millstab.api.next_test_elsewhere`); finite positive ones only."""
    nt = rec.next_test
    got = [rec.depth_mm] + ([nt["depth_mm"]] if "depth_mm" in nt and api.next_test_elsewhere(rec) is None else [])
    return [float(d) for d in got if d is not None and np.isfinite(d) and d > 0]



def _risk(value) -> float:
    """The form's risk: a probability in (0, 1) (``recommend --risk``'s rule, under the page's name)."""
    return api.check_risk(value, "risk P(chatter)")

class UpdateTab:
    def __init__(self, session: Session):
        self.s = session
        self.drop = dropper("test cuts CSV", POINTS_TYPES, css="drop-cuts")
        self.format = pn.pane.HTML('<span class="ms-note">columns rpm,depth_mm,label[,weight][,chatter_hz]; label '
                                   'stable, chatter or marginal; or a column <code>recording</code> naming a recording '
                                   'uploaded below (labels and chatter frequencies are then heard in it)</span>',
                                   width=330)
        # the recordings of the cuts (several files): uploaded name → where the session keeps it
        self.rec_drop = LimitedDropper(
            MAX_RECORDING_BYTES, MAX_RECORDINGS_TOTAL_BYTES,
            label=f"recordings of the cuts: {', '.join(RECORDING_TYPES)} (≤ {MAX_RECORDING_BYTES / 1e6:g} MB each, "
                  f"{MAX_RECORDINGS_TOTAL_BYTES / 1e6:g} MB in all)",
            accepted_filetypes=[], max_file_size=f"{MAX_RECORDING_BYTES / 1e6:g}MB",
            max_total_file_size=f"{MAX_RECORDINGS_TOTAL_BYTES / 1e6:g}MB", multiple=True, layout="compact",
            css_classes=["drop-recordings"], width=300)
        self.rec_error = pn.pane.HTML("", css_classes=["e-recordings-upload"])
        self.rec_note = pn.pane.HTML("", css_classes=["recordings-note"])  # which recordings a new upload replaced
        self.heard = pn.pane.HTML("", css_classes=["cuts-heard"])
        self.recordings: dict = {}
        self._rec_content: dict = {}  # uploaded name → the content saved for it (the drop zone's own object)
        self._saved = 0  # recordings saved in this session (each copy's number)
        self.cuts_csv = None  # (name, saved path) of a cuts CSV with a recording column
        self.drop_error = pn.pane.HTML("", css_classes=["e-cuts-upload"])
        self.cuts_note = pn.pane.HTML("", css_classes=["cuts-note"])
        self.use_points = pn.widgets.Checkbox(label="use the boundary points (Identify) as well", value=False)
        # no start= bound in the browser: below it the field kept showing the typed value (50) while the server kept
        # the last accepted one, and the update ran with 1000 samples; every value now reaches the server, which
        # checks it (checked_samples) and shows why it is refused beside the field
        self.samples = pn.widgets.IntInput(label="samples", value=1000, step=500, width=100,
                                           css_classes=["update-samples"])
        self.samples_error = pn.pane.HTML("", css_classes=["e-samples"])
        self.samples.param.watch(lambda e: self.checked_samples(), "value")
        self.seed = pn.widgets.IntInput(label="seed", value=0, width=80)
        # the update's engine and its discretisation (docs/app.md "Engine"): kept in the posterior, whose map and
        # recommendation use them; checked as --engine-option is (api.engine_options_from_text), on every edit
        self.engine = pn.widgets.Select(label="engine", options=list(api.ENGINES), value=api.cheapest_engine(),
                                        width=110, css_classes=["update-engine"])
        self.engine_options = pn.widgets.TextInput(label="engine options", value="", width=190,
                                                   placeholder="e.g. steps=40 (empty: the engine's own)",
                                                   css_classes=["update-engine-options"])
        self.engine_note = pn.pane.HTML("", css_classes=["update-engine-note"], width=520)
        self.engine_error = pn.pane.HTML("", css_classes=["e-engine-options"])
        self.engine.param.watch(lambda e: self._engine_changed(), "value")
        self.engine_options.param.watch(lambda e: self.checked_engine_options(), "value")
        self._engine_changed()
        self.job = JobBar("Update", "update")
        self.map_condition = ""  # "computed for ..." of the last map
        self.map_top = None  # (the map's top depth as asked [mm], where it came from) of the last map
        self.map_cuts = None  # the cuts the last map draws: those made in its condition
        self.post_origin = ""  # what the posterior was computed for (Session.origin when Update started)
        self.post_table = TextBox("post-table", width=None, height=None)
        self.depth_max = pn.widgets.FloatInput(label="map depth up to [mm]", value=None, width=150)
        # no start/end in the browser on these (see common.form_value): the server checks what is typed
        self.risk = pn.widgets.FloatInput(label="risk P(chatter)", value=0.05, step=0.01, width=120)
        # the target condition of the map and the recommendation (docs/updating.md, "Many conditions")
        self.target_ri = pn.widgets.FloatInput(label="for a/D (empty: the config's)", value=None, step=0.05,
                                               width=170, css_classes=["target-ri"])
        self.target_milling = pn.widgets.Select(label="milling", options=["config's", "down", "up"], width=100,
                                                css_classes=["target-milling"])
        self.map_job = JobBar("Map and recommend", "map")
        self.rec = TextBox("recommendation", width=900, height=None)
        self.plot = pn.Column(sizing_mode="stretch_width")
        self.pending = None  # the uploaded cuts not recorded in the open campaign yet (PointSet)
        self.campaign = None  # the campaign card (millstab.web.campaigns.CampaignPanel) with --db, else None
        self.post_id = None  # the database id of the shown posterior (an open campaign's), else None
        self.drop.param.watch(lambda e: self._cuts_uploaded(), "value")
        self.rec_drop.param.watch(lambda e: self._recordings_uploaded(), "value")
        self.job.run.on_click(lambda e: self.run())
        self.map_job.run.on_click(lambda e: self.map(record=True))

    # --- the update's engine -------------------------------------------------------------------------
    def _engine_changed(self) -> None:
        self.engine_note.object = f'<span class="ms-note">{esc(api.engine_update_note(self.engine.value))}</span>'
        self.checked_engine_options()

    def checked_engine_options(self) -> dict | None:
        """The engine options of the form for the chosen engine (``{}``: the engine's own choice), or ``None``
        after showing the one-line error beside the field (the same check and words as ``--engine-option``)."""
        try:
            options = api.engine_options_from_text(self.engine.value, self.engine_options.value)
        except InputError as exc:
            self.engine_error.object = error_html(str(exc))
            return None
        self.engine_error.object = ""
        return options

    def checked_samples(self) -> int | None:
        """The posterior samples of the form (:func:`millstab.api.check_samples`: 100 up to what this machine's
        memory holds), or ``None`` after showing why beside the field (an empty field is no number: it is not
        taken as 0 or as the last value)."""
        n, bad = form_value(self.samples, "samples", lambda v: api.check_samples(v, field="samples"),
                            "a whole number of posterior samples ≥ 100, e.g. 1000")
        self.samples_error.object = error_html(bad or "")
        return n

    def use_engine(self, engine: str, options: dict) -> None:
        """Show ``engine`` and its ``options`` in the form (an opened campaign's posterior: its next update
        continues from it only with the same ones)."""
        if engine in self.engine.options:
            self.engine.value = engine
        self.engine_options.value = ", ".join(f"{k}={v}" for k, v in sorted((options or {}).items()))

    def settings(self):
        """The update's settings from the form (:class:`millstab.api.UpdateSettings`: engine, engine_options,
        samples, seed), or ``None`` when the engine options or the samples are refused (the error is shown beside
        the field and in the job's status)."""
        options, samples = self.checked_engine_options(), self.checked_samples()
        if options is None or samples is None:
            which = "engine options" if options is None else "samples"
            self.job.status.text = error_html(f"{which}: see the error beside the field")
            return None
        seed, bad = form_value(self.seed, "seed", lambda v: api.check_seed(v, "seed"), "a whole number, e.g. 0")
        if bad:
            self.job.status.text = error_html(bad)
            return None
        return api.UpdateSettings(engine=self.engine.value, engine_options=options, samples=samples, seed=seed)

    # --- cuts with recordings ------------------------------------------------------------------------
    def _cuts_uploaded(self) -> None:
        """A cuts CSV: labelled rows (the points reader), or with a ``recording`` column, labelled by
        listening to the recordings it names (uploaded in this session only)."""
        from millstab.io.recordings import has_recording_column

        self.drop_error.object = self.heard.object = ""
        self.cuts_csv = None
        try:
            got = latest(self.drop, MAX_TEXT_BYTES, POINTS_TYPES, "points CSV")
        except InputError as exc:
            self.drop_error.object = error_html(str(exc))
            return
        if got is None:
            return
        path = save_in(self.s.folder, "cuts", *got)  # not an FRF: kept out of the session's FRF names
        if not has_recording_column(path):
            before = self.s.cuts
            points_upload(self.s, "cuts", self.drop, self.drop_error, self.cuts_note)
            if self.s.cuts is not before:
                self.pending = self.s.cuts
            return
        self.cuts_csv = (got[0], path)
        self._listen()

    def _forget_recording(self, name: str) -> None:
        """Drop the saved copy of recording ``name`` (its file too: the session's folder does not grow)."""
        self._rec_content.pop(name, None)
        path = self.recordings.pop(name, None)
        if path is not None:
            path.unlink(missing_ok=True)

    def _recordings_uploaded(self) -> None:
        """Save the recordings of the drop zone: a new name is saved, a name uploaded again with other content
        replaces its saved copy (the newest upload wins, and the page says so: a corrected recording uploaded
        under its old name used to leave the cuts labelled from the first one), a removed one is deleted."""
        self.rec_error.object = self.rec_note.object = ""
        errors, replaced = [], []
        value = self.rec_drop.value or {}
        for name in [n for n in self.recordings if n not in value]:  # removed from the drop zone ("tap to undo")
            self._forget_recording(name)
        for name, content in value.items():
            if name in self.recordings:
                old = self._rec_content.get(name)
                # the zone keeps one object per upload: the same object is the same upload; equal bytes of a new
                # one change nothing
                if old is content or old == content:
                    continue
                self._forget_recording(name)  # also when the new one is refused: the old one is not used
                replaced.append(name)
            try:
                check_type(name, RECORDING_TYPES, "recording")
                size = len(content.encode("utf-8")) if isinstance(content, str) else len(content)
                api.check_size(size, name, MAX_RECORDING_BYTES)
            except InputError as exc:
                errors.append(error_html(str(exc)))
                replaced = [n for n in replaced if n != name]  # said by its error instead
                continue
            # numbered: two names that reduce to the same safe name ("a b.wav", "a_b.wav") were one file, and a
            # cut was heard in the other's recording
            self._saved += 1
            self.recordings[name] = save_in(self.s.folder, f"rec{self._saved}", name, content)
            self._rec_content[name] = content
        self.rec_error.object = "".join(errors)
        if replaced:
            self.rec_note.object = ('<span class="ms-note">replaced by the newer upload: '
                                    f'{esc(", ".join(replaced))} (the cuts are heard in the new file)</span>')
        if self.cuts_csv is not None:
            self._listen()

    def _listen(self) -> None:
        """Label the uploaded cuts CSV by its recordings (:func:`millstab.api.label_from_recordings`); a
        recording cell may only name a file uploaded here (a server path is refused unopened)."""
        name, path = self.cuts_csv
        cfg = self.s.cfg
        if cfg is None:
            self.drop_error.object = error_html("need a valid config (Tool and cut): "
                                                "listening needs the number of teeth")
            return
        try:
            pts, notes = api.label_from_recordings(path, cfg.cutting.teeth, uploads=dict(self.recordings),
                                                   structure=cfg.structure)
        except InputError as exc:
            self.drop_error.object = error_html(str(exc))
            return
        self.drop_error.object = ""
        self.s.cuts = self.pending = pts
        self.cuts_note.object = (f'<span class="ms-done">{esc(name)}: {len(pts)} points, labels heard in the '
                                 'recordings</span>')
        # text, not numbers
        left = "<style>table.ms-table.heard td, table.ms-table.heard th { text-align: left; }</style>"
        self.heard.object = left + html_table(("cut", "label and where it came from"),
                                              [(str(i + 1), n) for i, n in enumerate(notes)], "heard")

    def run(self) -> None:
        if self.campaign is not None and self.campaign.current is not None:  # the open campaign, in the database
            self.run_campaign(self.campaign.current.name)
            return
        cfg, cuts = self.s.cfg, self.s.cuts
        if cfg is None or cuts is None:
            self.job.status.text = error_html("need a valid config (Tool and cut) and test cuts")
            return
        pts = self.s.points if self.use_points.value else None
        settings = self.settings()
        if settings is None:
            return
        origin = self.s.origin
        self.job.start(lambda progress: (api.update(cfg, cuts, pts, progress=progress, **settings.keywords()), origin),
                       self.show)

    def run_campaign(self, name: str, shop: str | None = None, new: bool = False) -> None:
        """Update campaign ``name`` in the database with the uploaded cuts (a new campaign: the tab's cuts),
        in the worker; then show it re-opened (:meth:`CampaignPanel.updated`)."""
        cfg = self.s.cfg
        cuts = (self.pending if self.pending is not None else self.s.cuts) if new else self.pending
        if cfg is None or (new and cuts is None):
            self.job.status.text = error_html("need a valid config (Tool and cut) and test cuts")
            return
        oc = self.campaign.current
        if (not new and cuts is None and oc is not None and oc.posterior is not None
                and oc.posterior_rows == len(oc.cuts)):
            self.job.status.text = error_html(f"campaign {name}: no new cuts; upload the new cuts to update it")
            return
        settings = self.settings()
        if settings is None:
            return
        work = self.campaign.update_work(name, cfg, cuts, settings, shop)
        self.job.start(work, lambda result, caught: self.campaign.updated(result))

    def clear_results(self) -> None:
        """Forget the shown posterior, map and recommendation (a campaign without a posterior was opened)."""
        self.s.post, self.s.pmap, self.s.map_post, self.s.rec, self.post_id = None, None, None, None, None
        self.post_table.text = self.rec.text = ""
        self.plot.objects = []

    def show(self, result, caught, record: bool = False, post_id=None) -> None:
        post, self.post_origin = result
        self.s.post, self.post_id = post, post_id
        theta = np.asarray(post.samples)
        q = np.percentile(theta, [5, 50, 95], axis=0)
        # in the units of the form and the command line (k in N/µm): in N/m, 8.0027e+06 beside a form's "9 N/um"
        scale = [api.SHOWN_UNITS.get(u, (1.0, u)) for u in post.prior.units()]
        rows = [(n, f"{a * f:.5g}", f"{b * f:.5g}", f"{c * f:.5g}", unit)
                for n, a, b, c, (f, unit) in zip(post.names, q[0], q[1], q[2], scale)]
        lines = list(post.warnings) + [w for w in caught if w not in post.warnings]
        opts = ", ".join(f"{k}={v}" for k, v in sorted(post.engine_options.items())) or "its own discretisation"
        self.post_table.text = (computed_for(self.post_origin)
                                + f'<div class="ms-note">engine {esc(post.engine)} ({esc(opts)}), '
                                  f'{len(theta)} samples</div>'
                                + html_table(("parameter", "5 %", "median", "95 %", "unit"), rows, "posterior")
                                + "".join(f'<div class="ms-note">{esc(w)}</div>' for w in lines))
        if post.engine != api.cheapest_engine():  # minutes of the engine for every sample: only when asked
            # those of the last posterior are not this one's
            self.s.pmap, self.s.map_post, self.s.rec = None, None, None
            self.rec.text = ""
            self.plot.objects = []
            self.map_job.status.text = (f'<span class="ms-note">the map and recommendation call {esc(post.engine)} '
                                        'for every sample (minutes): press Map and recommend</span>')
            return
        self.map(record=record)

    def map(self, record: bool = False) -> None:
        """The P(stable) map and the recommendation; ``record``: the recommendation of an open campaign's
        current posterior is recorded in the database (its history shows it)."""
        post, cfg, cuts = self.s.post, self.s.cfg, self.s.cuts
        if post is None or cfg is None:
            self.map_job.status.text = error_html("run Update first")
            return
        risk, bad = form_value(self.risk, "risk P(chatter)", _risk, "a probability in (0, 1), e.g. 0.05")
        if bad:
            self.map_job.status.text = error_html(bad)
            return
        r = np.asarray(api.speeds(None, cfg))
        cheap = post.engine == api.cheapest_engine()
        rpm = np.linspace(r.min(), r.max(), MAP_SPEEDS if cheap else MAP_SPEEDS_ACCURATE)
        grid = {} if cheap else {"coarse_points": MAP_SPEEDS_ACCURATE}
        top = self.depth_max.value or (float(1.5 * np.max(cuts.depth_mm)) if cuts is not None else 5.0)
        if not top or top <= 0:
            self.map_job.status.text = error_html(f"map depth up to = {top}: must be > 0 mm")
            return
        oc = self.campaign.current if self.campaign is not None else None
        keep = oc is not None and record and self.post_id is not None and self.post_id == oc.posterior_id
        mill = None if self.target_milling.value == "config's" else self.target_milling.value
        try:
            post = api.for_condition(post, radial_immersion=self.target_ri.value, milling=mill)
        except InputError as exc:
            self.map_job.status.text = error_html(str(exc))
            return
        # an accurate engine's map reads a seeded subsample (api.map_samples): its error is stated beside it
        self.map_condition = f"{api.condition_line(post)}; P(stable) from {api.map_samples_text(post)}"
        # the map draws the cuts made in its condition; one in another belongs to another boundary
        self.map_cuts, elsewhere = api.cuts_in_condition(post, cuts, cfg.cutting) if cuts is not None else (None, 0)
        if elsewhere:
            self.map_condition += f"; {elsewhere} cut{'s' if elsewhere > 1 else ''} in other conditions not drawn"

        def work(progress):
            api.depth_grid(top, field="map depth up to")  # a bad depth is refused before any engine call
            # the map and the recommendation share the limits both read (the map's speeds are the recommendation's
            # coarse grid; its subsample holds the fast search's): computed once, the same numbers, in either order
            memo = api.limit_memo()
            span = (float(rpm[0]), float(rpm[-1]))
            if keep:  # recorded with the posterior it came from
                rec = self.campaign.v.recommend(oc.name, risk, span, current=(self.post_id, post), **grid)[0]
            else:
                rec = api.recommend(post, risk, span, memo=memo, **grid)
            # the map's depths reach the cuts drawn on it (the recommended one, the next test here): a marker above
            # the top was drawn off the axes and the user saw no recommendation (show_map says the axis was raised)
            depth = api.depth_grid(max([top] + [MARK_HEADROOM * d for d in marked_depths(rec)]),
                                   field="map depth up to")
            pm = api.p_stable(post, rpm, depth, memo=memo)
            return rpm, depth, pm, rec, post

        self.map_top = (top, "map depth up to" if self.depth_max.value else "1.5 × the deepest cut")
        self.map_job.start(work, self.show_map)

    def show_map(self, result, caught) -> None:
        rpm, depth, pm, rec, map_post = result
        if self.campaign is not None and self.campaign.current is not None:
            self.campaign.reload_history()
        # the map's posterior (moved to the target condition) first: the downloads draw it when pmap changes
        self.s.map_post = map_post
        self.s.pmap, self.s.rec = (rpm, depth, pm), rec
        nt = rec.next_test
        marks = [(rec.rpm, rec.depth_mm, "recommended")]
        # a next test in another condition (it teaches the shared parameters more) is not on this map's boundary:
        # said with its condition, not drawn here
        other = api.next_test_elsewhere(rec)
        if "rpm" in nt and "depth_mm" in nt and other is None:
            marks.append((nt["rpm"], nt["depth_mm"], "next test"))
        where = (f" <b>in another condition: {esc(other)}</b> (not drawn on this map; {esc(nt.get('why', ''))})"
                 if other is not None else "")
        raised = ""
        if self.map_top is not None and depth[-1] > self.map_top[0] * (1 + 1e-9):
            top, asked = self.map_top
            above = " and ".join({"recommended": "the recommended cut"}.get(text, f"the {text}")
                                 for _, d, text in marks if d > top)
            raised = f"; depth axis raised from {top:.3g} mm ({asked}) to {depth[-1]:.3g} mm to show {above}"
        self.plot.objects = [pn.pane.Bokeh(map_figure(rpm, depth, pm, self.map_cuts, marks=marks),
                                           sizing_mode="stretch_width")]
        # the map and the recommendation may say one thing each in the same words (dict: once each, in order)
        notes = "".join(f'<div class="ms-note">{esc(w)}</div>' for w in dict.fromkeys(caught))
        self.rec.text = (computed_for(self.post_origin)
                         + f"<div class='ms-note'>{esc(self.map_condition + raised)}</div>"
                         f"<b>recommended</b> at risk {rec.risk:g}: <b>{rec.rpm:.0f} rpm, {rec.depth_mm:.3g} mm</b> "
                           f"(P(chatter) {rec.p_chatter:.3f}, limited by {esc(rec.limited_by)})<br>"
                           f"<b>next test cut</b>: {nt.get('rpm', float('nan')):.0f} rpm, "
                           f"{nt.get('depth_mm', float('nan')):.3g} mm (P(chatter) "
                           f"{nt.get('p_chatter', float('nan')):.2f}){where}{notes}")

    def view(self):
        head = [self.campaign.view()] if self.campaign is not None else []
        inputs = pn.Card(pn.Column(self.drop, self.format, self.drop_error, self.cuts_note),
                         pn.Column(self.rec_drop, self.rec_error, self.rec_note, self.heard), self.use_points,
                         pn.Row(self.samples, self.seed, self.engine, self.engine_options),
                         pn.Column(self.samples_error, self.engine_error, self.engine_note), self.job,
                         self.post_table.view(),
                         title="Test cuts and Bayesian update", collapsible=False)
        decide = pn.Card(pn.Row(self.depth_max, self.risk, self.target_ri, self.target_milling, self.map_job),
                         self.rec.view(), title="P(stable) and recommendation", collapsible=False)
        return pn.Column(*head, inputs, decide, self.plot, name="Update and recommend")
