"""Config files: cutting conditions and tool-tip structure in TOML, with explicit units.

Schema (every quantity a number in SI or a string with units, parsed by
:func:`millstab.units.parse_quantity`)::

    name = "Ex.1"                # optional; default: the file name without extension
    description = "..."          # optional, free text

    [cutting]
    teeth = 2                    # positive integer
    kt = "556.31 MPa"            # tangential coefficient; also "556.31 N/mm^2"; plain number = N/m^2
    kr = 0.404                   # Kr = Kn/Kt (the seed paper's k_n), >= 0
    entry = "0 deg"              # entry and exit angles (plain number = rad), 0 <= entry < exit <= 180 deg
    exit = "180 deg"
    # instead of entry/exit:
    # radial_immersion = 0.2     # a/D in (0, 1]; also "20 %"
    # milling = "down"           # "down" or "up"; required unless radial_immersion = 1
    # diameter = "12 mm"         # optional: the tool diameter (a cuts file's radial_width_mm column needs it;
    #                            # a [tool] table's diameter serves too)
    # feed_per_tooth = "0.1 mm"  # optional: the feed per tooth of the cuts (simulate; the removal rate)

    [[structure.x]]              # one table per mode; a direction without modes is rigid
    fn = "903 Hz"                # also "0.903 kHz"; "5674 rad/s" = 903 Hz (÷2π), "54180 rpm" = 903 Hz (÷60)
    k = "12.53 N/um"
    zeta = 0.03
    [[structure.y]]
    fn = "903 Hz"
    k = "12.53 N/um"
    zeta = 0.03

    # or a measured FRF instead of modes (paths relative to this file; .csv, .frf, .uff/.unv):
    # [structure.frf]
    # xx = "tap_xx.csv"
    # yy = { file = "tap.uff", record = 1 }   # UFF: 0-based index among the dataset-58 records
    # xy = ...; yx = ...                       # optional cross terms

    [speeds]                     # optional: default spindle speeds of this config [rev/min]
    start = 2000                 # plain numbers are rpm; "5000 rpm" also works
    stop = 12000                 # inclusive
    step = 10

    [prior]                      # optional: the prior of `millstab update` (Bayesian updating)
    fn = "5 %"                   # log-normal spread of every natural frequency (default 5 %)
    k = "30 %"                   # ... of every stiffness (default 30 %), zeta: of every damping ratio (30 %)
    fn_x = "3 %"                 # one parameter's own spread (names as in millstab.params)
    kt = "10 %"                  # frees Kt (cutting coefficients are fixed unless given a spread)
    process_damping = "50 %"     # frees the process-damping C (needs cutting.process_damping and diameter; sdm)
    fixed = ["zeta_y"]           # parameters held at the structure's values
    sigma_depth = "0.05 mm"      # depth noise of the stability likelihood; or relative, "5 %"
    sigma_chatter_hz = "20 Hz"   # noise of a measured chatter frequency
    label_error = "2 %"          # probability that a cut's label is swapped, in [0, 50 %) (default 2 %)
    tails = "student"            # tails: multivariate_t_shift (default), multivariate_t, student, normal, mixture
    batch_effect = "3 %"         # σ of a test day's shift of every fn (cuts' batch/date column; default off)
    chatter_hz_alias = "100 %"   # chance a chatter frequency is not the family member near the mode (default 10 %)

A spread is the standard deviation of ln(value) (≈ the relative standard deviation when small),
a plain number or a percentage, > 0. ``sigma_depth`` needs its unit ("mm") or a "%".

Every problem raises :class:`InputError` naming the field (``structure.x[0].k``, ``cutting.kt``),
the value as written (``cutting.exit = '270 deg'``, not its SI value) and what is allowed. Unknown
keys are errors (with the allowed keys), so a typo cannot pass silently; so are units of the wrong
kind, angle content included (``kr = "2 deg"``, ``fn = "2 rad"``; see :mod:`millstab.units`), and
numbers with a decimal comma (``fn = 900,5`` or ``"900,5 Hz"``, which pint would read as 9005).
The file is UTF-8, with or without a byte-order mark (Notepad); UTF-16 with a mark is read too.
"""

from __future__ import annotations

import math
import re
import tomllib
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from millstab.bounds import MAX_MODE_HZ, MAX_MODES
from millstab.errors import InputError, show
from millstab.io.results import PathLike, atomic_write_text
from millstab.io.text import looks_like, read_text
from millstab.config import MAX_BATCH_EFFECT, Config, PriorTable  # the model types (Config: import it from there)
from millstab.model import LARGEST_DIAMETER, Cutting, Mode, Structure
from millstab.points import milling_word
from millstab.units import parse_quantity

TOP_KEYS = ("name", "description", "cutting", "structure", "speeds", "prior", "tool", "holder")
#: keys of [prior] besides parameter names (fn_x, k_y2, ...), the kinds fn/k/zeta and kt/kr
PRIOR_KEYS = ("fixed", "sigma_depth", "sigma_chatter_hz", "label_error", "tails", "batch_effect", "chatter_hz_alias")
#: the prior's tails (millstab.update.prior.TAILS)
PRIOR_TAILS = ("student", "normal", "mixture", "multivariate_t", "multivariate_t_shift")
_PRIOR_NAME = re.compile(r"^(fn|k|zeta)(?:_([xy]))?(\d*)$|^(kt|kr|process_damping)$")
CUTTING_KEYS = ("teeth", "kt", "kr", "entry", "exit", "radial_immersion", "milling", "process_damping", "diameter",
                "feed_per_tooth")
STRUCTURE_KEYS = ("x", "y", "frf")
MODE_KEYS = ("fn", "k", "zeta")
FRF_KEYS = ("xx", "yy", "xy", "yx")
SPEED_KEYS = ("start", "stop", "step")
#: the most speeds a [speeds] table may produce (a larger grid is almost surely a typo)
MAX_SPEEDS = 1_000_000
#: hints for keys people are likely to type
_HINTS = {"kn": "the radial coefficient ratio is called kr (= Kn/Kt, the paper's k_n)",
          "ks": "give kt and kr (not the specific force Ks)", "n": "the number of teeth is 'teeth'",
          "flutes": "the number of teeth is 'teeth'", "wn": "give fn in Hz", "f": "the natural frequency is 'fn'",
          "xi": "the damping ratio is 'zeta'", "damping": "the damping ratio is 'zeta'", "stiffness": "use 'k'"}


def _check_keys(table: Any, field: str, allowed: Iterable[str], required: Iterable[str] = ()) -> Mapping[str, Any]:
    allowed = tuple(allowed)
    if not isinstance(table, Mapping):
        raise InputError(field, table, f"must be a table with keys {', '.join(allowed)}")
    for key in table:
        if key not in allowed:
            hint = _HINTS.get(str(key).lower())
            raise InputError(f"{field}.{key}" if field else str(key), table[key],
                             f"unknown key{f' ({hint})' if hint else ''}; allowed keys in "
                             f"{field or 'the top level'}: {', '.join(allowed)}")
    for key in required:
        if key not in table:
            raise InputError(f"{field}.{key}" if field else key, None,
                             f"missing; [{field}] requires {', '.join(required)}")
    return table


@contextmanager
def _as_written(raw: Mapping[str, Any]):
    """Re-raise an :class:`InputError` about one of ``raw``'s fields with the value the user wrote.

    The model classes validate SI floats, so their errors would echo ``cutting.exit = 4.71...`` for
    ``exit = "270 deg"`` or ``k = -3000000.0`` for ``k = "-3 N/um"``.
    """
    try:
        yield
    except InputError as exc:
        if exc.field in raw:
            raise InputError(exc.field, raw[exc.field], exc.allowed) from None
        raise


def _angle(value: Any, field: str) -> float:
    x = parse_quantity(value, field, "angle")
    if not -1e-12 <= x <= math.pi + 1e-12:
        hint = (f"; a plain number means radians, write \"{value} deg\" for degrees"
                if isinstance(value, (int, float)) else "")
        raise InputError(field, value, f"angle must be in [0, pi] rad (0..180 deg){hint}")
    return x


def _cutting(t: Any) -> Cutting:
    t = _check_keys(t, "cutting", CUTTING_KEYS, ("teeth", "kt", "kr"))
    teeth = t["teeth"]
    if isinstance(teeth, bool) or not isinstance(teeth, int):
        raise InputError("cutting.teeth", teeth, "number of teeth must be a positive integer (e.g. teeth = 4)")
    kt = parse_quantity(t["kt"], "cutting.kt", "pressure")
    kr = parse_quantity(t["kr"], "cutting.kr", "dimensionless")
    extra = _process_damping(t)
    written = {f"cutting.{k}": t[k] for k in ("process_damping", "diameter") if k in t}
    has_angles = "entry" in t or "exit" in t
    if has_angles and ("radial_immersion" in t or "milling" in t):
        raise InputError("cutting.radial_immersion" if "radial_immersion" in t else "cutting.milling",
                         t.get("radial_immersion", t.get("milling")),
                         "give either entry/exit angles or radial_immersion (with milling), not both")
    if has_angles:
        for key in ("entry", "exit"):
            if key not in t:
                raise InputError(f"cutting.{key}", None, "missing; entry and exit are given together")
        entry, exit_ = _angle(t["entry"], "cutting.entry"), _angle(t["exit"], "cutting.exit")
        if entry >= exit_:
            raise InputError("cutting.entry", t["entry"], f"entry angle must be less than the exit angle "
                                                          f"(exit = {show(t['exit'])})")
        with _as_written({f"cutting.{k}": t[k] for k in ("kt", "kr", "entry", "exit")} | written):
            return Cutting(teeth, kt, kr, entry, exit_, **extra)
    if "radial_immersion" not in t:
        raise InputError("cutting.entry", None,
                         "missing; give entry and exit angles (slotting: \"0 deg\", \"180 deg\") "
                         "or radial_immersion and milling = \"down\" | \"up\"")
    ri = parse_quantity(t["radial_immersion"], "cutting.radial_immersion", "dimensionless")
    milling = t.get("milling")
    if milling is None:
        if ri != 1.0:
            raise InputError("cutting.milling", None,
                             "missing; with radial_immersion < 1 give milling = \"down\" or \"up\"")
        milling = "down"
    milling = milling_word(milling) if isinstance(milling, str) else milling
    if milling not in ("down", "up"):
        raise InputError("cutting.milling", milling, 'must be "down" or "up" (climb = down, conventional = up)')
    with _as_written({f"cutting.{k}": t[k] for k in ("kt", "kr", "radial_immersion")} | written):
        return Cutting.from_immersion(teeth, kt, kr, ri, milling, **extra)


def _process_damping(t: Mapping[str, Any]) -> dict[str, float]:
    """``process_damping`` (the coefficient C, N/m: "2e5 N/m", "0.2 N/um") and the tool ``diameter``
    (a length, "16 mm") of [cutting], as Cutting keywords; the model checks them (C ≥ 0, D > 0, D with C)."""
    extra = {}
    if "process_damping" in t:
        extra["process_damping"] = parse_quantity(t["process_damping"], "cutting.process_damping", "stiffness")
    if "diameter" in t:  # a face mill may measure ~1 m: not the 0.2 m of a [tool] beam
        extra["diameter"] = _tool_length(t, "diameter", "cutting", top=LARGEST_DIAMETER)
    return extra


def _modes(value: Any, direction: str) -> tuple[Mode, ...]:
    field = f"structure.{direction}"
    if isinstance(value, Mapping):  # [structure.x] (single brackets): one mode
        value = [value]
    if not isinstance(value, list):
        raise InputError(field, value, f"must be a list of modes: one [[{field}]] table per mode with fn, k, zeta")
    if len(value) > MAX_MODES:
        raise InputError(field, f"{len(value)} modes", f"at most {MAX_MODES} modes per direction (a tap test's fit "
                                                         "holds a few; more makes every engine call slow)")
    modes = []
    for i, m in enumerate(value):
        name = f"{field}[{i}]"
        m = _check_keys(m, name, MODE_KEYS, MODE_KEYS)
        fn = parse_quantity(m["fn"], f"{name}.fn", "frequency")
        if fn > MAX_MODE_HZ:
            raise InputError(f"{name}.fn", m["fn"], f"a tool-tip mode's natural frequency, at most "
                                                    f"{MAX_MODE_HZ:,.0f} Hz (rad/s? rpm? an extra zero?)")
        k = parse_quantity(m["k"], f"{name}.k", "stiffness")
        zeta = parse_quantity(m["zeta"], f"{name}.zeta", "dimensionless")
        with _as_written({f"{name}.{key}": m[key] for key in MODE_KEYS}):
            modes.append(Mode(fn, k, zeta, name))
    return tuple(modes)


def _structure(t: Any, base_dir: Path | None, files: Mapping[str, PathLike] | None = None) -> Structure:
    t = _check_keys(t, "structure", STRUCTURE_KEYS)
    if "frf" in t:
        if t.get("x") or t.get("y"):
            raise InputError("structure", "modes and [structure.frf]",
                             "give either modes ([[structure.x]], [[structure.y]]) or a measured FRF, not both")
        frf_t = _check_keys(t["frf"], "structure.frf", FRF_KEYS)
        from millstab.io.frf_files import load_measured_frf

        frf = load_measured_frf(**{k: frf_t[k] for k in FRF_KEYS if k in frf_t}, base_dir=base_dir,
                                field="structure.frf", files=files)
        return Structure(frf=frf)
    x = _modes(t.get("x", []), "x")
    y = _modes(t.get("y", []), "y")
    if not x and not y:
        raise InputError("structure", "no modes", "at least one mode is required: add [[structure.x]] and/or "
                                                  "[[structure.y]] tables with fn, k, zeta (or a [structure.frf])")
    return Structure(x=x, y=y)


def _rpm_value(value: Any, field: str) -> float:
    """A spindle speed in rpm: a plain number (rpm) or a string with units (``"5000 rpm"``)."""
    if isinstance(value, bool):
        raise InputError(field, value, "expected a spindle speed in rpm")
    if isinstance(value, (int, float)):
        x = float(value)
    elif isinstance(value, str):
        # only rev/min is accepted: a speed written in Hz or rad/s is refused with its rpm value
        # as a hint rather than converted, so that [speeds] always reads as written
        m = _RPM.fullmatch(value)
        try:
            x = float(m.group(1)) if m else math.nan
        except ValueError:
            x = math.nan
        if math.isnan(x):
            raise InputError(field, value, "expected a spindle speed in rpm, e.g. 5000 or \"5000 rpm\" "
                                           f"(plain number = rpm){_rpm_hint(value, field)}")
    else:
        raise InputError(field, value, "expected a spindle speed in rpm")
    if not math.isfinite(x) or x <= 0:
        raise InputError(field, value, "spindle speed must be a finite number > 0 rpm")
    return x


_RPM = re.compile(r"\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)\s*(rpm|rev/min|r/min|1/min|min\^-1|min-1)?\s*", re.IGNORECASE)


def _rpm_hint(value: str, field: str) -> str:
    """``"; "100 Hz" is 6000 rpm"`` for a speed written in another unit of rotational frequency."""
    try:
        hz = parse_quantity(value, field, "frequency")
    except InputError as exc:
        return "; numbers must use a decimal point" if "decimal point" in exc.allowed else ""
    return f"; {value.strip()!r} is {hz * 60:.10g} rpm as a rotational speed: write that"


def parse_batch_effect(value, field: str = "prior.batch_effect") -> float:
    """The test-day spread τ (σ of a day's shift of ln fn) from ``"3 %"``, ``"3%"`` or ``0.03``.

    Raises:
        InputError: not a number or percentage in [0, :data:`MAX_BATCH_EFFECT`].
    """
    tau = parse_quantity(value, field, "dimensionless")
    if not 0 <= tau <= MAX_BATCH_EFFECT:
        raise InputError(field, value, f"the σ of a test day's shift of every natural frequency, in [0 %, "
                                       f"{MAX_BATCH_EFFECT:.0%}], e.g. \"3 %\" (0: no test-day effect)")
    return tau


def with_batch_effect(cfg: Config, value, field: str = "--batch-effect") -> Config:
    """``cfg`` with its ``[prior] batch_effect`` set from ``value`` (``None``: ``cfg`` unchanged)."""
    if value is None:
        return cfg
    table = cfg.prior if cfg.prior is not None else PriorTable({})
    return replace(cfg, prior=replace(table, batch_effect=parse_batch_effect(value, field)))


def _prior(t: Any) -> PriorTable:
    if not isinstance(t, Mapping):
        raise InputError("prior", t, "must be a table of spreads, e.g. [prior] fn = \"5 %\"")
    spreads: dict[str, float] = {}
    fixed: tuple[str, ...] = ()
    sd_m = sd_rel = sf = eps = tails = batch = alias = None
    for key, value in t.items():
        field = f"prior.{key}"
        if key == "fixed":
            if not (isinstance(value, list)
                    and all(isinstance(v, str) and (_PRIOR_NAME.match(v.strip())
                                                    or v.strip() in ("label_error", "sigma_depth")) for v in value)):
                raise InputError(field, value, "must be a list of parameter names, e.g. [\"zeta_y\"] (or label_error, "
                                               "sigma_depth: held at their values instead of learned)")
            fixed = tuple(v.strip() for v in value)
        elif key == "sigma_depth":
            if not isinstance(value, str):
                raise InputError(field, value, "give the unit: an absolute depth noise such as \"0.05 mm\" or a "
                                               "relative one such as \"5 %\"")
            if "%" in value:
                sd_rel = parse_quantity(value, field, "dimensionless")
                if not 0 < sd_rel < 1:
                    raise InputError(field, value, "a relative depth noise must be in (0 %, 100 %)")
            else:
                sd_m = parse_quantity(value, field, "length")
                if sd_m <= 0:
                    raise InputError(field, value, "depth noise must be > 0 mm")
        elif key == "sigma_chatter_hz":
            sf = parse_quantity(value, field, "frequency")
            if sf <= 0:
                raise InputError(field, value, "chatter-frequency noise must be > 0 Hz")
        elif key == "label_error":
            eps = parse_quantity(value, field, "dimensionless")
            if not 0 <= eps < 0.5:
                raise InputError(field, value, "the probability that a cut's label is swapped must be in [0, 0.5) "
                                               "(a number such as 0.02 or a percentage such as \"2 %\"; 0: never)")
        elif key == "chatter_hz_alias":
            alias = parse_quantity(value, field, "dimensionless")
            if not 0 < alias <= 1:
                raise InputError(field, value, "the chance that a chatter frequency is another member of its family "
                                               "than the one near the mode, in (0, 100 %] (e.g. \"10 %\" for "
                                               "`millstab listen`'s frequencies; 100 %: any member alike)")
        elif key == "tails":
            if value not in PRIOR_TAILS:
                raise InputError(field, value, f"one of {', '.join(PRIOR_TAILS)}")
            tails = value
        elif key == "batch_effect":
            batch = parse_batch_effect(value, field)
        elif isinstance(key, str) and _PRIOR_NAME.match(key):
            x = parse_quantity(value, field, "dimensionless")
            if x <= 0:
                raise InputError(field, value, "a prior spread must be > 0 (to hold a parameter, list it in fixed)")
            spreads[key] = x
        else:
            raise InputError(field, value, f"unknown key; allowed in [prior]: fn, k, zeta, a parameter name (fn_x, "
                                           f"k_y2, ...), kt, kr, process_damping, {', '.join(PRIOR_KEYS)}")
    return PriorTable(spreads, fixed, sd_m, sd_rel, sf, eps, tails, batch, alias)


def _speeds(t: Any) -> np.ndarray:
    t = _check_keys(t, "speeds", SPEED_KEYS, SPEED_KEYS)
    start, stop, step = (_rpm_value(t[k], f"speeds.{k}") for k in SPEED_KEYS)
    if stop <= start:
        raise InputError("speeds.stop", t["stop"], f"must be greater than speeds.start ({start:g} rpm)")
    n = math.floor((stop - start) / step + 1e-9) + 1
    if n > MAX_SPEEDS:
        raise InputError("speeds.step", t["step"], f"gives {n} speeds; at most {MAX_SPEEDS} allowed")
    return start + step * np.arange(n)


def config_from_dict(data: Mapping[str, Any], name: str = "config", path: Path | None = None,
                     base_dir: Path | None = None, files: Mapping[str, PathLike] | None = None) -> Config:
    """Build a :class:`Config` from parsed TOML (a dict); ``base_dir`` resolves relative FRF paths.
    ``files`` ({name: path}) confines the ``[structure.frf]`` file names to its keys
    (:func:`millstab.io.frf_files.load_measured_frf`): nothing else is opened."""
    data = _check_keys(data, "", TOP_KEYS)
    for key in ("cutting", "structure"):
        if key not in data and not (key == "structure" and "tool" in data):
            raise InputError(key, None, "missing; a config needs [cutting] and [structure] tables "
                                        "(or [tool] and [holder] instead of [structure])")
    name_value = data.get("name", name)
    if not isinstance(name_value, str):
        raise InputError("name", name_value, "must be a string")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise InputError("description", description, "must be a string")
    cutting = _cutting(data["cutting"])
    setup = None
    diameter, feed = _cutting_sizes(data["cutting"], data.get("tool"), cutting)
    if "tool" in data or "holder" in data:
        structure, setup = _tool_structure(data, base_dir, files)
    else:
        structure = _structure(data["structure"], base_dir, files)
    rpm = _speeds(data["speeds"]) if "speeds" in data else None
    prior = _prior(data["prior"]) if "prior" in data else None
    return Config(cutting, structure, name_value, path, rpm, description, prior, setup, diameter, feed)


def _cutting_sizes(t: Mapping[str, Any], tool: Any, cutting: Cutting) -> tuple[float | None, float | None]:
    """(tool diameter [m] or None, feed per tooth [m] or None) of ``[cutting]`` (its ``diameter``, read into
    ``cutting.diameter``; else a ``[tool]`` table's)."""
    d = None
    if "diameter" in t:
        d = cutting.diameter  # read and checked with the cutting (_process_damping)
    elif isinstance(tool, Mapping) and "diameter" in tool:
        d = _tool_length(tool, "diameter", "tool")
    f = None
    if "feed_per_tooth" in t:
        f = parse_quantity(t["feed_per_tooth"], "cutting.feed_per_tooth", "length")
        if not 0 < f <= 0.01:
            raise InputError("cutting.feed_per_tooth", t["feed_per_tooth"],
                             "a feed per tooth in (0, 10] mm, with its unit (e.g. \"0.1 mm\"; a plain number is m)")
    return d, f


def parse_config(text: str, name: str = "config", base_dir: PathLike | None = None,
                 files: Mapping[str, PathLike] | None = None, source: str | None = None) -> Config:
    """Parse config TOML text (``path`` of the result is ``None``); ``files`` as in :func:`config_from_dict`;
    ``source``: the file the text came from (an upload's name), named by the errors of the text as a whole (TOML
    syntax, nesting; default ``name``).

    Text has no folder: without ``base_dir`` (the caller's word for where its FRF files are) and without
    ``files``, a ``[structure.frf]`` file name is refused, never looked up from the working directory
    or as an absolute path (the text may come from anyone: an upload)."""
    if base_dir is None and files is None:
        files = {}
    data = _toml(text.lstrip("\ufeff"), source or name)
    return config_from_dict(data, name, None, Path(base_dir) if base_dir is not None else None, files)


def load_config(source: PathLike) -> Config:
    """Load a config file, or a packaged example with ``"example:NAME"`` (e.g. ``"example:ex1"``).

    Raises:
        InputError: file missing, TOML syntax error (file name and line), or any schema problem.
    """
    if isinstance(source, str) and source.startswith("example:"):
        from millstab.io.examples import example_path

        path = example_path(source.split(":", 1)[1])
        default_name = path.stem
    else:
        path = Path(source).expanduser()
        default_name = path.stem
        if not path.is_file():
            raise InputError("config", str(source), "file does not exist" if not path.exists() else "is not a file")
    text = read_text(path, "config", "text (TOML) file")  # a byte-order mark (Notepad) is dropped
    return config_from_dict(_toml(text, str(path)), default_name, path, path.parent)


def _toml(text: str, source: str) -> dict:
    """The TOML tables of ``text``; its syntax errors, and a nesting too deep for Python's recursive TOML parser
    (a RecursionError that no door showed: an upload of arrays nested 5 000 deep left the page silent), as an
    :class:`InputError` naming ``source`` (the file).
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:  # the message carries "(at line L, column C)"
        kind = looks_like(text)
        seems = f"; the file looks like {kind}, not a TOML config: is it in the config's place?" if kind else ""
        raise InputError(source, "TOML syntax error", f"{exc}{_comma_hint(text)}{seems}") from None
    except RecursionError:
        raise InputError(source, "arrays or inline tables nested too deeply to read",
                         "a config nests a few levels ([structure] → x → its modes); this text nests arrays or "
                         "inline tables ({ } or [ ]) hundreds of levels deep: is it the config meant?") from None


_TOML_COMMA = re.compile(r"^\s*[\w.\-\"']+\s*=\s*[-+]?\d+,\d+\s*(#.*)?$")


def _comma_hint(text: str) -> str:
    """A hint naming the first line whose value is a number with a decimal comma (``fn = 900,5``)."""
    for no, line in enumerate(text.splitlines(), start=1):
        if _TOML_COMMA.match(line):
            return f"; line {no} ({line.strip()!r}) uses a decimal comma: write numbers with a decimal point"
    return ""


def _fmt(x: float) -> str:
    return f"{x:.15g}"


def config_to_toml(config: Config) -> str:
    """TOML text of a config with a modal structure, in the schema above (trade units, 15 digits).

    Raises:
        InputError: for a measured-FRF structure (its data live in separate files).
    """
    if not config.structure.is_modal:
        raise InputError("structure", "measured FRF", "only modal structures can be written as a config")
    c = config.cutting
    lines = [f"name = {_toml_str(config.name)}"]
    if config.description:
        lines.append(f"description = {_toml_str(config.description)}")
    lines += ["", "[cutting]", f"teeth = {c.teeth}", f'kt = "{_fmt(c.kt / 1e6)} MPa"', f"kr = {_fmt(c.kr)}",
              f'entry = "{_fmt(math.degrees(c.entry))} deg"', f'exit = "{_fmt(math.degrees(c.exit))} deg"']
    if c.has_process_damping:
        lines.append(f'process_damping = "{_fmt(c.process_damping)} N/m"')
    if c.diameter is not None:
        lines.append(f'diameter = "{_fmt(c.diameter * 1e3)} mm"')
    if config.feed_per_tooth_m is not None:
        lines.append(f'feed_per_tooth = "{_fmt(config.feed_per_tooth_m * 1e3)} mm"')
    for d in ("x", "y"):
        for m in getattr(config.structure, d):
            lines += ["", f"[[structure.{d}]]", f'fn = "{_fmt(m.fn)} Hz"', f'k = "{_fmt(m.k / 1e6)} N/um"',
                      f"zeta = {_fmt(m.zeta)}"]
    if config.rpm is not None and config.rpm.size >= 2:
        r = config.rpm
        lines += ["", "[speeds]", f"start = {_fmt(r[0])}", f"stop = {_fmt(r[-1])}", f"step = {_fmt(r[1] - r[0])}"]
    if config.prior is not None:
        lines += ["", "[prior]"] + _prior_lines(config.prior)
    return "\n".join(lines) + "\n"


def _prior_lines(p: PriorTable) -> list[str]:
    """The ``[prior]`` table as written by a user (only what they set; spreads as plain σ of ln)."""
    out = [f"{_toml_key(k)} = {_fmt(v)}" for k, v in p.spreads.items()]
    if p.fixed:
        out.append("fixed = [" + ", ".join(_toml_str(f) for f in p.fixed) + "]")
    if p.sigma_depth_m is not None:
        out.append(f'sigma_depth = "{_fmt(p.sigma_depth_m * 1e3)} mm"')
    if p.sigma_depth_rel is not None:
        out.append(f'sigma_depth = "{_fmt(p.sigma_depth_rel * 100)} %"')
    if p.sigma_chatter_hz is not None:
        out.append(f'sigma_chatter_hz = "{_fmt(p.sigma_chatter_hz)} Hz"')
    if p.label_error is not None:
        out.append(f"label_error = {_fmt(p.label_error)}")
    if getattr(p, "tails", None) is not None:
        out.append(f"tails = {_toml_str(p.tails)}")
    if getattr(p, "batch_effect", None) is not None:
        out.append(f'batch_effect = "{_fmt(p.batch_effect * 100)} %"')
    if getattr(p, "chatter_hz_alias", None) is not None:
        out.append(f'chatter_hz_alias = "{_fmt(p.chatter_hz_alias * 100)} %"')
    return out


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _toml_str(k)


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def write_config(path: PathLike, config: Config, protect: Iterable[PathLike] = ()) -> Path:
    """Write a modal config as TOML (atomic; refuses to overwrite a ``protect`` file)."""
    return atomic_write_text(path, config_to_toml(config), protect)


# ------------------------------------------------------------------ [tool] + [holder] (docs/tooltip.md)

TOOL_KEYS = ("diameter", "stickout", "fluted_length", "flute_diameter_ratio", "material", "E", "density", "nu",
             "zeta")
HOLDER_KEYS = ("rigid", "modes", "frf", "artifact", "finite_differences")
FD_KEYS = ("spacing", "h00", "h01", "h11", "h02", "h12", "h22", "diameter", "material", "E", "density", "nu")
HOLDER_MODE_KEYS = ("fn", "k", "zeta", "slope")
HOLDER_FRF_KEYS = ("h", "l", "n", "p")
ARTIFACT_KEYS = ("diameter", "length", "offset", "material", "E", "density", "nu", "zeta", "tip", "cross",
                 "offset_direct")
#: the largest plausible lengths [m] of a tool's diameter and stickout (a bigger one is mm written as m)
_MAX_LENGTH = {"diameter": 0.2, "stickout": 1.0, "fluted_length": 1.0, "length": 1.0, "offset": 1.0}


def _tool_length(t: Mapping[str, Any], key: str, field: str, default: float | None = None,
                 top: float | None = None) -> float:
    """``t[key]`` as a length [m] > 0 and at most ``top`` [m] (default :data:`_MAX_LENGTH`'s for ``key``): a bigger
    plain number is mm written as m, and the message says so."""
    if key not in t:
        if default is None:
            raise InputError(f"{field}.{key}", None, f"missing; give it with its unit, e.g. {key} = \"12 mm\"")
        return default
    value = t[key]
    x = parse_quantity(value, f"{field}.{key}", "length")
    if x <= 0:
        raise InputError(f"{field}.{key}", value, "must be a length > 0, e.g. \"12 mm\"")
    top = _MAX_LENGTH.get(key, 1.0) if top is None else top
    if x > top:
        # "did you mean mm" only for a length written in metres (12, "12 m"): "250 mm" over a [tool]'s 0.2 m was
        # asked "did you mean 0.25 mm?"
        plain = isinstance(value, (int, float))
        lead = re.match(r"\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)", str(value))
        in_metres = plain or (lead is not None and math.isclose(float(lead.group(1)), x, rel_tol=1e-9))
        hint = ""
        if in_metres:
            hint = ("; a plain number means metres:" if plain else ";") + f" did you mean \"{x:g} mm\"?"
        raise InputError(f"{field}.{key}", value, f"is {x:g} m, more than {top:g} m for a tool's {key}{hint}")
    return x


def _material(t: Mapping[str, Any], field: str):
    from millstab.tooltip.beam import Material, material
    from millstab.units import _parse_string

    if "material" in t:
        if "E" in t or "density" in t:
            raise InputError(f"{field}.material", t["material"],
                             "give either a material name or E and density, not both")
        return material(t["material"])
    if "E" not in t or "density" not in t:
        raise InputError(f"{field}.material", None, "missing; give material = \"carbide\" (or steel, hss, aluminium) "
                                                    "or E = \"600 GPa\" and density = \"14600 kg/m^3\"")
    E = parse_quantity(t["E"], f"{field}.E", "pressure")
    rho_raw = t["density"]
    allowed = "a density, e.g. \"14600 kg/m^3\" (plain number = kg/m^3)"
    rho = (float(rho_raw) if isinstance(rho_raw, (int, float)) and not isinstance(rho_raw, bool)
           else _parse_string(str(rho_raw), f"{field}.density", "kg/m**3", 0, allowed))
    nu = parse_quantity(t.get("nu", 0.3), f"{field}.nu", "dimensionless")
    if not 1e9 <= E <= 2e12:
        raise InputError(f"{field}.E", t["E"], "Young's modulus of a tool or holder material must be 1..2000 GPa "
                                               "(a plain number is Pa: write \"600 GPa\")")
    if not 500 <= rho <= 30000:
        raise InputError(f"{field}.density", rho_raw, "must be 500..30000 kg/m^3 (a plain number is kg/m^3)")
    with _as_written({f"material.{k}": t.get(k) for k in ("E", "density", "nu")}):
        return Material("custom", E, rho, nu, "given in the config")


def _tool(t: Any):
    from millstab.tooltip.tool import DEFAULT_FLUTE_RATIO, Tool

    t = _check_keys(t, "tool", TOOL_KEYS, ("diameter", "stickout"))
    d = _tool_length(t, "diameter", "tool")
    stick = _tool_length(t, "stickout", "tool")
    fl = _tool_length(t, "fluted_length", "tool", 0.0) if "fluted_length" in t else 0.0
    if fl > stick * (1 + 1e-9):
        raise InputError("tool.fluted_length", t["fluted_length"],
                         f"must not exceed the stickout ({show(t['stickout'])})")
    ratio = parse_quantity(t.get("flute_diameter_ratio", DEFAULT_FLUTE_RATIO), "tool.flute_diameter_ratio",
                           "dimensionless")
    zeta = parse_quantity(t.get("zeta", 0.0), "tool.zeta", "dimensionless")
    raw = {f"tool.{k}": t[k] for k in ("diameter", "stickout", "zeta") if k in t}
    raw["tool.flute_diameter_ratio"] = t.get("flute_diameter_ratio", DEFAULT_FLUTE_RATIO)
    with _as_written(raw):
        return Tool(d, stick, _material(t, "tool"), fl, ratio, zeta)


def _holder_term(src: Any, field: str, base_dir: Path | None,
                 files: Mapping[str, PathLike] | None = None) -> tuple[np.ndarray, np.ndarray]:
    from millstab.io.frf_files import _source, read_frf

    p, record = _source(src, field, base_dir, files)  # a config from text: only its session's uploads
    try:
        f, h = read_frf(p, record)
    except InputError as exc:
        raise InputError(field, exc.value, f"{exc.field}: {exc.allowed}") from None
    return (f[1:], h[1:]) if f[0] == 0.0 else (f, h)


def _on_axis(terms: Mapping[str, tuple[np.ndarray, np.ndarray]], first: str, field: str) -> tuple[np.ndarray, dict]:
    """All terms on the axis of ``first``, trimmed to the band every term covers (interpolated where needed)."""
    lo = max(f[0] for f, _ in terms.values())
    hi = min(f[-1] for f, _ in terms.values())
    f0 = terms[first][0]
    f = f0[(f0 >= lo * (1 - 1e-12)) & (f0 <= hi * (1 + 1e-12))]
    if f.size < 4:
        raise InputError(field, f"common band {lo:g}..{hi:g} Hz", "the files must share at least 4 frequencies")
    return f, {k: np.interp(f, fk, hk.real) + 1j * np.interp(f, fk, hk.imag) for k, (fk, hk) in terms.items()}


def _holder(t: Any, base_dir: Path | None, files: Mapping[str, PathLike] | None = None):
    """The [holder] table: one description for both directions, or [holder.x] and [holder.y]."""
    from millstab.tooltip import holder as hm

    if isinstance(t, Mapping) and ("x" in t or "y" in t):
        _check_keys(t, "holder", ("x", "y"), ("x", "y"))
        return hm.XYHolder(_holder_one(t["x"], base_dir, "holder.x", files),
                           _holder_one(t["y"], base_dir, "holder.y", files))
    return _holder_one(t, base_dir, "holder", files)


def _holder_one(t: Any, base_dir: Path | None, field: str, files: Mapping[str, PathLike] | None = None):
    from millstab.tooltip import holder as hm

    t = _check_keys(t, field, HOLDER_KEYS)
    given = [k for k in HOLDER_KEYS if k in t and not (k == "rigid" and t[k] is False)]
    if len(given) != 1:
        raise InputError(field, ", ".join(given) or "nothing",
                         "give exactly one of: rigid = true, [[holder.modes]] (fn, k, zeta, slope), [holder.frf] "
                         "(h, l, n, p files), [holder.artifact] (an artifact test) or [holder.finite_differences]; "
                         "or [holder.x] and [holder.y], one each")
    kind = given[0]
    if kind == "rigid":
        if t["rigid"] is not True:
            raise InputError(f"{field}.rigid", t["rigid"], "must be true (or leave it out and describe the holder)")
        return hm.RigidHolder()
    if kind == "modes":
        value = t["modes"]
        modes = []
        for i, m in enumerate(value if isinstance(value, list) else [value]):
            name = f"{field}.modes[{i}]"
            m = _check_keys(m, name, HOLDER_MODE_KEYS, ("fn", "k", "zeta"))
            fn = parse_quantity(m["fn"], f"{name}.fn", "frequency")
            k = parse_quantity(m["k"], f"{name}.k", "stiffness")
            zeta = parse_quantity(m["zeta"], f"{name}.zeta", "dimensionless")
            slope = _slope(m.get("slope", 0.0), f"{name}.slope")
            with _as_written({f"holder mode {a}": m.get(a) for a in HOLDER_MODE_KEYS}):
                modes.append(hm.FaceMode(fn, k, zeta, slope))
        return hm.ModalHolder(tuple(modes))
    if kind == "frf":
        raw_t = t["frf"]
        if isinstance(raw_t, Mapping):  # H, L, N, P as the literature writes them are accepted too
            raw_t = {str(k).lower() if str(k) in "HLNP" else k: v for k, v in raw_t.items()}
        ft = _check_keys(raw_t, f"{field}.frf", HOLDER_FRF_KEYS, ("h", "p"))
        if "l" not in ft and "n" not in ft:
            raise InputError(f"{field}.frf.l", None,
                             "missing; give l (w/m) or n (theta/f), or both (equal by reciprocity)")
        terms = {k: _holder_term(ft[k], f"{field}.frf.{k}", base_dir, files) for k in HOLDER_FRF_KEYS if k in ft}
        f, v = _on_axis(terms, "h", f"{field}.frf")
        l_, n_ = v.get("l", v.get("n")), v.get("n", v.get("l"))
        return hm.MeasuredHolder(f, v["h"], l_, n_, v["p"], source=f"{field}.frf files")
    if kind == "finite_differences":
        return _holder_fd(t["finite_differences"], base_dir, f"{field}.finite_differences", files)
    at = _check_keys(t["artifact"], f"{field}.artifact", ARTIFACT_KEYS,
                     ("diameter", "length", "offset", "tip", "cross", "offset_direct"))
    d = _tool_length(at, "diameter", f"{field}.artifact")
    length = _tool_length(at, "length", f"{field}.artifact")
    off = _tool_length(at, "offset", f"{field}.artifact")
    if off >= length:
        raise InputError(f"{field}.artifact.offset", at["offset"],
                         f"must be less than the artifact's length ({show(at['length'])})")
    art = hm.artifact_beam(d, length, off, _material(at, f"{field}.artifact"))
    zeta = parse_quantity(at.get("zeta", 0.0), f"{field}.artifact.zeta", "dimensionless")
    if not 0.0 <= zeta < 0.5:
        raise InputError(f"{field}.artifact.zeta", at["zeta"],
                         "the artifact's damping ratio must be in [0, 0.5) (a steel "
                         "cylinder: ~0.001, or leave it out: 0)")
    art = replace(art, eta=2.0 * zeta)
    terms = {k: _holder_term(at[k], f"{field}.artifact.{k}", base_dir, files)
             for k in ("tip", "cross", "offset_direct")}
    f, v = _on_axis(terms, "tip", f"{field}.artifact")
    return hm.from_artifact(f, v["tip"], v["cross"], v["offset_direct"], art, off)


def _holder_fd(t: Any, base_dir: Path | None, field: str, files: Mapping[str, PathLike] | None = None):
    """[holder.finite_differences]: translational FRFs h_ij at points i·spacing from the face toward the spindle
    (h00, h01, h11; with h02, h12, h22 the second-order stencil), optionally the holder's diameter at the
    face (and material) for the shear correction (docs/tooltip.md)."""
    from millstab.tooltip import holder as hm
    from millstab.tooltip.beam import Section

    t = _check_keys(t, field, FD_KEYS, ("spacing", "h00", "h01", "h11"))
    second = [k for k in ("h02", "h12", "h22") if k in t]
    if second and len(second) != 3:
        raise InputError(f"{field}.{second[0]}", t[second[0]],
                         "the second-order stencil needs h02, h12 and h22 together")
    order = 2 if second else 1
    spacing = _tool_length(t, "spacing", field)
    n = order + 1
    names = [f"h{i}{j}" for i in range(n) for j in range(i, n)]
    terms = {k: _holder_term(t[k], f"{field}.{k}", base_dir, files) for k in names}
    f, v = _on_axis(terms, "h00", field)
    H = np.empty((f.size, n, n), dtype=complex)
    for i in range(n):
        for j in range(i, n):
            H[:, i, j] = H[:, j, i] = v[f"h{i}{j}"]  # reciprocity
    shear = None
    if "diameter" in t:
        mat = _material(t, field) if ("material" in t or "E" in t) else _material({"material": "steel"}, field)
        shear = Section(spacing, _tool_length(t, "diameter", field), mat).shear_stiffness
    return hm.from_finite_differences(f, H, spacing, order, shear_stiffness=shear)


def _slope(value: Any, field: str) -> float:
    """A mode's rotation per displacement at the face: a plain number (rad/m) or text such as "20 rad/m"."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    from millstab.units import _parse_string

    # pint counts the radian as an angle the length dimension lacks: read "rad/m" as 1/m
    return _parse_string(re.sub(r"\brad\s*/", "1/", str(value)), field, "1/m", 0,
                         "a rotation per displacement, e.g. \"20 rad/m\" (plain number = rad/m)")


def tool_setup(data: Mapping[str, Any], base_dir: Path | None = None, files: Mapping[str, PathLike] | None = None):
    """``(Tool, Holder)`` from a config's ``[tool]`` and ``[holder]`` tables (parsed TOML)."""
    if "tool" not in data or "holder" not in data:
        missing = "holder" if "tool" in data else "tool"
        raise InputError(missing, None, "missing; [tool] and [holder] are given together (the holder: rigid = true, "
                                        "[[holder.modes]], [holder.frf] or [holder.artifact])")
    return _tool(data["tool"]), _holder(data["holder"], base_dir, files)


def _tool_structure(data: Mapping[str, Any], base_dir: Path | None,
                    files: Mapping[str, PathLike] | None = None) -> tuple[Structure, tuple]:
    """(the tip FRF structure, (Tool, Holder)) of a [tool] + [holder] config."""
    if "structure" in data:
        raise InputError("structure", "[structure] and [tool]", "give either [structure] (modes or a measured FRF) or "
                                                                "[tool] + [holder], not both")
    from millstab.errors import FRFWarning
    from millstab.tooltip.holder import RigidHolder
    from millstab.tooltip.tool import tip_structure
    from millstab.warnlog import warn

    tool, holder = tool_setup(data, base_dir, files)
    if isinstance(holder, RigidHolder) and tool.zeta == 0:
        warn("tool.zeta: the tool has no damping and the holder is rigid, so the tip FRF is undamped and every "
             "stability limit near its modes is ~0; give the tool's damping, e.g. zeta = 0.01 (a carbide end mill "
             "in a holder: ~0.5-3 %), or describe the holder (its damping)", FRFWarning, stacklevel=2)
    return tip_structure(tool, holder), (tool, holder)


def load_tool_setup(source: PathLike):
    """``(Config, Tool, Holder)`` of a config file (or ``example:NAME``) with ``[tool]`` and ``[holder]``."""
    cfg = load_config(source)
    data = tomllib.loads(read_text(cfg.path, "config", "text (TOML) file"))
    if "tool" not in data:
        raise InputError("config", str(source), "has no [tool] table; `millstab tooltip` needs [tool] and [holder]")
    tool, holder = tool_setup(data, cfg.path.parent)
    return cfg, tool, holder


def tool_setup_from_text(text: str, name: str = "config", base_dir: PathLike | None = None,
                         files: Mapping[str, PathLike] | None = None):
    """``(Config, Tool, Holder)`` from config TOML text; ``base_dir`` and ``files`` as :func:`parse_config`
    (without either, a holder file name is refused, never looked up)."""
    if base_dir is None and files is None:
        files = {}
    cfg = parse_config(text, name, base_dir, files)
    data = tomllib.loads(text.lstrip("\ufeff"))
    if "tool" not in data:
        raise InputError(name, "no [tool]", "`millstab tooltip` needs [tool] and [holder]")
    return (cfg, *tool_setup(data, Path(base_dir) if base_dir is not None else None, files))


__all__ = ["PriorTable", "config_from_dict", "config_to_toml", "load_config", "load_tool_setup", "parse_batch_effect",
           "parse_config", "tool_setup", "tool_setup_from_text", "with_batch_effect", "write_config"]
