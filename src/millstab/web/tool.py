"""Tab "Tool and cut": cutting conditions, structure (modes per direction, or uploaded FRF files), speeds;
or a packaged example, or an uploaded config TOML. The fields hold values as a TOML config writes them
(units included) and go through the config file's validators (:func:`millstab.api.config_from_fields`);
a problem is shown next to the field it names."""

from __future__ import annotations

import tomllib
from pathlib import Path

import panel as pn

from millstab import api
from millstab.errors import InputError
from millstab.io.frf_files import frf_csv_text
from millstab.io.text import decode_text
from millstab.web.common import Field, as_text, error_html, esc
from millstab.web.state import Session
from millstab.web.uploads import CONFIG_TYPES, FRF_TYPES, MAX_FRF_BYTES, MAX_TEXT_BYTES, dropper, latest

DEFAULT_EXAMPLE = "ex3"
FRF_TERMS = ("xx", "yy", "xy", "yx")


class ModeList:
    """The modes of one direction: rows of fn, k, zeta fields and buttons to add or remove a row."""

    def __init__(self, direction: str, changed):
        self.direction = direction
        self.changed = changed
        self.rows: list[tuple[Field, Field, Field]] = []
        self.box = pn.Column(margin=0)
        self.add = pn.widgets.Button(label=f"+ {direction} mode", width=110, css_classes=[f"add-{direction}"])
        self.remove = pn.widgets.Button(label=f"− {direction} mode", width=110, css_classes=[f"remove-{direction}"])
        self.add.on_click(lambda e: (self.append({"fn": "1000 Hz", "k": "10 N/um", "zeta": 0.03}), self.changed()))
        self.remove.on_click(lambda e: (self.pop(), self.changed()))

    def view(self):
        return pn.Column(pn.pane.HTML(f"<b>{self.direction} direction</b> (one row per mode)"), self.box,
                         pn.Row(self.add, self.remove), margin=(0, 10))

    def append(self, mode: dict) -> None:
        i = len(self.rows)
        key = f"structure.{self.direction}[{i}]"
        row = (Field("fn", as_text(mode["fn"]), f"{key}.fn"), Field("k", as_text(mode["k"]), f"{key}.k"),
               Field("zeta", as_text(mode["zeta"]), f"{key}.zeta", width=90))
        for f in row:
            f.input.param.watch(lambda e: self.changed(), "value")
        self.rows.append(row)
        self.box.append(pn.Row(*(f.view() for f in row), margin=0))

    def pop(self) -> None:
        if self.rows:
            self.rows.pop()
            self.box.pop(-1)

    def set(self, modes: list) -> None:
        self.rows.clear()
        self.box.clear()
        for m in modes:
            self.append(m)

    def fields(self) -> list[Field]:
        return [f for row in self.rows for f in row]

    def tables(self) -> list[dict]:
        return [{"fn": a.value, "k": b.value, "zeta": c.value} for a, b, c in self.rows]


class ToolTab:
    """The form; on every committed edit (Enter or leaving a field) it validates and sets ``session.cfg``."""

    def __init__(self, session: Session):
        self.s = session
        self._filling = False
        self.extra: dict = {}  # tables the form does not show ([prior], description) kept from a loaded config
        ch = self.changed
        self.name = Field("name", "", "name", width=200)
        self.teeth = Field("teeth", "", "cutting.teeth", width=80)
        self.kt = Field("kt", "", "cutting.kt")
        self.kr = Field("kr = Kn/Kt", "", "cutting.kr", width=100)
        self.geometry = pn.widgets.RadioButtonGroup(options=["entry/exit angles", "radial immersion"],
                                                    value="entry/exit angles", css_classes=["geometry"])
        self.entry = Field("entry", "", "cutting.entry")
        self.exit = Field("exit", "", "cutting.exit")
        self.immersion = Field("radial_immersion (a/D)", "0.2", "cutting.radial_immersion", width=150)
        self.milling = pn.widgets.Select(label="milling", options=["down", "up"], value="down", width=90)
        self.start = Field("start [rpm]", "", "speeds.start", width=100)
        self.stop = Field("stop [rpm]", "", "speeds.stop", width=100)
        self.step = Field("step [rpm]", "", "speeds.step", width=100)
        self.structure_kind = pn.widgets.RadioButtonGroup(options=["modes", "measured FRF"], value="modes",
                                                          css_classes=["structure-kind"])
        self.modes = {d: ModeList(d, ch) for d in ("x", "y")}
        self.frf_drop = {t: dropper(f"H{t} FRF", FRF_TYPES, MAX_FRF_BYTES, css=f"drop-frf-{t}") for t in FRF_TERMS}
        self.frf_error = {t: pn.pane.HTML("", css_classes=[f"e-structure-frf-{t}"]) for t in FRF_TERMS}
        self.frf_note = {t: pn.pane.HTML("", css_classes=[f"frf-note-{t}"]) for t in FRF_TERMS}
        #: the FRF term sources of the form: a saved upload's file name, or {"file": that, "record": N}
        self.frf_files: dict[str, str | dict] = {}
        self.source = ""  # what the form was last filled from (Session.origin says it with "edited")
        self.edited = False
        self.waiting: tuple[str, bytes | str] | None = None  # an uploaded config waiting for the FRF files it names
        for t, w in self.frf_drop.items():
            w.param.watch(lambda e, t=t: self._frf_uploaded(t), "value")
        self.example = pn.widgets.Select(label="packaged example", options=api.list_examples(), value=DEFAULT_EXAMPLE,
                                         width=150, css_classes=["example"])
        self.load_example = pn.widgets.Button(label="Load example", width=120, css_classes=["load-example"])
        self.config_drop = dropper("config TOML", CONFIG_TYPES, MAX_TEXT_BYTES, css="drop-config")
        self.config_error = pn.pane.HTML("", css_classes=["e-config-upload"])
        self.general = pn.pane.HTML("", css_classes=["e-general"])
        self.status = pn.pane.HTML("", css_classes=["tool-status"])
        self.load_example.on_click(lambda e: self.fill_example(self.example.value))
        self.config_drop.param.watch(lambda e: self._config_uploaded(), "value")
        for f in self.simple_fields():
            f.input.param.watch(lambda e: ch(), "value")
        for w in (self.geometry, self.milling, self.structure_kind):
            w.param.watch(lambda e: ch(), "value")
        self.angles_row = pn.Row(self.entry.view(), self.exit.view())
        self.immersion_row = pn.Row(self.immersion.view(), self.milling, visible=False)
        self.geometry.param.watch(lambda e: self._geometry_shown(), "value")
        self.fill_example(DEFAULT_EXAMPLE)

    def _geometry_shown(self) -> None:
        angles = self.geometry.value == "entry/exit angles"
        self.angles_row.visible, self.immersion_row.visible = angles, not angles

    def simple_fields(self) -> list[Field]:
        return [self.name, self.teeth, self.kt, self.kr, self.entry, self.exit, self.immersion, self.start, self.stop,
                self.step]

    def all_fields(self) -> list[Field]:
        return self.simple_fields() + self.modes["x"].fields() + self.modes["y"].fields()

    # --- filling the form from a config -------------------------------------------------------------------
    def fill(self, cfg, source: str, frf: dict | None = None) -> None:
        """Show ``cfg`` in the fields (values with units as the config writer writes them, [prior] and
        description kept as written by it); ``source`` says where it came from. A measured-FRF config
        comes with ``frf``, its ``[structure.frf]`` table naming the session's saved uploads; the mode
        rows are then left as they are."""
        # the io config writer is the one source of the tables (a form-side copy of it dropped
        # [prior] label_error: a config loaded in the browser changed the prior of an update)
        t = api.config_fields(cfg)  # a measured-FRF config: no structure table (the form shows ``frf``)
        self._filling = True
        try:
            c = t["cutting"]
            self.name.input.value = t.get("name", "")
            self.teeth.input.value, self.kt.input.value, self.kr.input.value = (
                as_text(c[k]) for k in ("teeth", "kt", "kr"))
            self.geometry.value = "entry/exit angles"
            self.entry.input.value, self.exit.input.value = as_text(c["entry"]), as_text(c["exit"])
            sp = t.get("speeds") or {"start": 2000, "stop": 12000, "step": 20}
            self.start.input.value, self.stop.input.value, self.step.input.value = (
                as_text(sp[k]) for k in ("start", "stop", "step"))
            if frf is None:
                self.structure_kind.value = "modes"
                for d in ("x", "y"):
                    self.modes[d].set(t.get("structure", {}).get(d, []))
            else:
                self.structure_kind.value = "measured FRF"
                self.frf_files = dict(frf)
                for term in FRF_TERMS:
                    self.frf_note[term].object = ""
            self.extra = {k: t[k] for k in ("description", "prior") if k in t}
            self.source, self.edited = source, False
        finally:
            self._filling = False
        self._changed()

    def fill_example(self, name: str) -> None:
        try:
            self.fill(api.config(f"example:{name}"), f"the packaged example {name}")
        except InputError as exc:
            self.general.object = error_html(str(exc))

    def load_text(self, text: str, name: str, source: str) -> None:
        """Show a config text (a campaign's, from the shop database) in the form; ``source`` says whose.
        FRF files it names must be uploads of this session, as for an uploaded config.

        Raises:
            InputError: the text is not a valid config here.
        """
        self.fill(api.config_from_text(text, name, files=self.s.uploads), source)

    def _config_uploaded(self) -> None:
        self.config_error.object = ""
        self.waiting = None
        try:
            got = latest(self.config_drop, MAX_TEXT_BYTES, CONFIG_TYPES, "config TOML")
        except InputError as exc:
            self.config_error.object = error_html(str(exc))
            return
        if got is not None:
            self._load_config(*got)

    def _load_config(self, name: str, content: bytes | str) -> None:
        self.config_error.object = ""
        try:
            # FRF file names in it resolve to this session's uploads only: nothing else is opened
            cfg = api.config_from_text(content, name, files=self.s.uploads)
            if cfg.structure.is_modal:
                frf, written = None, None
            elif "tool" in tomllib.loads(_text(content, name).lstrip("\ufeff")):
                frf, written = self._tip_files(cfg, name), {}
            else:
                frf, written = self._frf_table(content, name)
        except InputError as exc:
            waits = (exc.field.startswith("structure.frf.") and "uploaded in the same session" in exc.allowed
                     and Path(str(exc.value)).name == exc.value and not str(exc.value).startswith("~"))
            # a config that names FRF files not uploaded yet loads when they are (upload order is free)
            self.waiting = (name, content) if waits else None
            note = (f'<div class="ms-note">{esc(name)} loads once the FRF files it names are uploaded in the FRF drop '
                    'zones below</div>' if waits else "")
            self.config_error.object = error_html(str(exc)) + note
            return
        self.waiting = None
        self.fill(cfg, f"uploaded {name}", frf)
        if frf is not None and not written:  # a [tool] + [holder] config: its tip FRF, computed here
            for term, file in frf.items():
                self.frf_note[term].object = (f'<span class="ms-note">{esc(name)}: the tool tip by receptance '
                                              f'coupling ([tool] + [holder]), saved as {esc(file)}</span>')
        elif frf is not None:
            for term, src in written.items():
                file = src["file"] if isinstance(src, dict) else src
                record = f" record {src['record']}" if isinstance(src, dict) and "record" in src else ""
                self.frf_note[term].object = f'<span class="ms-note">{esc(name)}: {esc(file)}{esc(record)}</span>'

    def _tip_files(self, cfg, name: str) -> dict:
        """A ``[tool]`` + ``[holder]`` config's tool-tip FRF (computed by the config reader) saved in the
        session's folder as FRF CSV files, one per term: the form then shows it as a measured FRF, and its
        config download names those files (the [tool] description is not kept by the form)."""
        frf = cfg.structure.frf
        out = {}
        for term in FRF_TERMS:
            h = getattr(frf, term, None)
            if h is not None:
                file = f"{Path(name).stem}_tip_{term}.csv"
                self.s.save_upload(term, file, frf_csv_text(frf.freq_hz, h))
                out[term] = self.s.uploads[file].name
        return out

    def _frf_table(self, content: bytes | str, name: str) -> tuple[dict, dict]:
        """The ``[structure.frf]`` table of an uploaded config (already validated) naming the saved files,
        and as written."""
        table = tomllib.loads(_text(content, name).lstrip("\ufeff"))["structure"]["frf"]
        out: dict[str, str | dict] = {}
        for term, src in table.items():
            if isinstance(src, dict):
                out[term] = {**src, "file": self.s.uploads[src["file"]].name}
            else:
                out[term] = self.s.uploads[src].name
        return out, table

    def _frf_uploaded(self, term: str) -> None:
        self.frf_error[term].object = ""
        self.frf_note[term].object = ""
        try:
            got = latest(self.frf_drop[term], MAX_FRF_BYTES, FRF_TYPES, "FRF")
        except InputError as exc:
            self.frf_error[term].object = error_html(str(exc))
            return
        if got is None:
            self.frf_files.pop(term, None)
        else:
            self.frf_files[term] = self.s.save_upload(term, *got).name
        self.structure_kind.value = "measured FRF"
        self.changed()
        if got is not None and self.waiting is not None:
            self._load_config(*self.waiting)

    # --- validation -------------------------------------------------------------------------------------
    def tables(self) -> dict:
        cutting = {"teeth": self.teeth.value, "kt": self.kt.value, "kr": self.kr.value}
        if self.geometry.value == "entry/exit angles":
            cutting.update(entry=self.entry.value, exit=self.exit.value)
        else:
            cutting.update(radial_immersion=self.immersion.value, milling=self.milling.value)
        if self.structure_kind.value == "modes":
            structure = {d: m.tables() for d, m in self.modes.items() if m.rows}
        else:
            structure = {"frf": dict(self.frf_files)}
        out = {"name": str(self.name.input.value).strip() or "config", **self.extra, "cutting": cutting,
               "structure": structure,
               "speeds": {"start": self.start.value, "stop": self.stop.value, "step": self.step.value}}
        return out

    def changed(self) -> None:
        if self._filling:
            return
        self.edited = True
        self._changed()

    def origin(self) -> str:
        """What the form's config is, as the result panes say it."""
        if self.source.startswith(("uploaded", "campaign")):
            return self.source + (", edited in the form" if self.edited else "")
        return f"{self.source}{', edited in the form' if self.edited else ''} — no config loaded"

    def _changed(self) -> None:
        for f in self.all_fields():
            f.error.object = ""
        for t in FRF_TERMS:
            if t in self.frf_files:  # an upload's own error (too large) stays until the next upload
                self.frf_error[t].object = ""
        self.general.object = ""
        try:
            with api.collect_warnings() as caught:  # this session's warnings only (see millstab.warnlog)
                # the form's FRF terms name the session's saved uploads, and nothing else can be opened
                cfg = api.config_from_fields(self.tables(), "config", files=self.s.saved)
        except InputError as exc:
            self.show_error(exc)
            self.status.object = error_html("input not valid: the diagrams show the last valid input")
            return
        # a warning about one field (a unit slip: "structure.x[0].k = 12.53 N/m is very low ...") stands under it,
        # and the status says the config is valid but to be checked (the hint sat under a green "valid")
        fields = {f.key: f for f in self.all_fields()}
        marked = [w for w in caught if str(w.message).split(" = ", 1)[0] in fields]
        for w in marked:
            fields[str(w.message).split(" = ", 1)[0]].error.object = f'<span class="ms-warn">{esc(w.message)}</span>'
        notes = "".join(f'<div class="ms-note">{esc(w.message)}</div>' for w in caught if w not in marked)
        origin = self.origin()
        state = (f'<span class="ms-done">valid: {esc(cfg.name)}</span>' if not marked else
                 f'<span class="ms-warn">valid, but check {len(marked)} marked field{"s" if len(marked) > 1 else ""}: '
                 f'{esc(cfg.name)}</span>')
        self.status.object = f'{state} <span class="ms-note">({esc(origin)})</span>{notes}'
        self.s.origin = origin  # before cfg: the tabs redraw on cfg and say what they computed for
        self.s.cfg = cfg

    def show_error(self, exc: InputError) -> None:
        fields = {f.key: f for f in self.all_fields()}
        key = exc.field
        if key in fields:
            fields[key].error.object = error_html(str(exc))
            return
        for t in FRF_TERMS:
            if key.startswith(f"structure.frf.{t}"):
                self.frf_error[t].object = error_html(str(exc))
                return
        self.general.object = error_html(str(exc))

    # --- layout -----------------------------------------------------------------------------------------
    def view(self, preview=None):
        source = pn.Card(pn.Row(pn.Column(self.example, self.load_example),
                                pn.Column(self.config_drop, self.config_error)),
                         title="Start from a packaged example or a config TOML", collapsible=False)
        cutting = pn.Card(pn.Row(self.name.view(), self.teeth.view(), self.kt.view(), self.kr.view()),
                          self.geometry, self.angles_row, self.immersion_row,
                          pn.pane.HTML('<span class="ms-note">Units as in a TOML config: kt "2173 N/mm^2" or '
                                       '"2173 MPa"; angles "126.9 deg" (plain number = rad); fn "900 Hz"; k "9 N/um"; '
                                       'plain numbers are SI. Press Enter or leave a field to apply.</span>'),
                          title="Cutting conditions", collapsible=False)
        frf = pn.GridBox(*(pn.Column(self.frf_drop[t], self.frf_note[t], self.frf_error[t]) for t in FRF_TERMS),
                         ncols=2)
        structure = pn.Card(self.structure_kind, pn.Row(self.modes["x"].view(), self.modes["y"].view()),
                            pn.pane.HTML("<b>or measured FRF</b> (choose \"measured FRF\"; at least xx or yy):"), frf,
                            title="Structure (tool tip)", collapsible=False)
        speeds = pn.Card(pn.Row(self.start.view(), self.stop.view(), self.step.view()), title="Spindle speeds",
                         collapsible=False)
        form = pn.Column(self.status, self.general, source, cutting, structure, speeds)
        if preview is None:
            return pn.Column(form, name="Tool and cut")
        return pn.Row(form, pn.Column(pn.pane.Bokeh(preview), styles={"position": "sticky", "top": "0"}),
                      name="Tool and cut")


def _text(content: bytes | str, name: str) -> str:
    return content if isinstance(content, str) else decode_text(content, name, name, "text file (TOML)")
