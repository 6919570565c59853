"""Bayesian updating as services: the posterior from labelled cuts, P(stable) maps, the recommended cut
and the next test (:mod:`millstab.update`), with the checks every door shares."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from millstab.api.inputs import config, modal
from millstab.api.inputs import points as point_set
from millstab.progress import Progress
from millstab.bounds import samples as check_samples
from millstab.bounds import check_cuts
from millstab.bounds import seed as check_seed
from millstab.errors import InputError
from millstab.parsing import check_risk
from millstab.points import PointSet
from millstab.points import condition_text  # re-exported too: "a/D 0.25 up milling, 4 teeth" for the doors
from millstab.io.config import with_batch_effect  # noqa: F401 (re-exported: the doors' --batch-effect)
from millstab.config import Config
from millstab.points import PointSet

#: the most cells (speeds × depths) of one P(stable) map
MAX_MAP_CELLS = 5_000_000


@dataclass(frozen=True)
class UpdateSettings:
    """How an update samples: the keywords of :func:`update` of the same names and defaults, as one object
    that the doors (the app's form, ``millstab update``) and the shop database (:func:`millstab.api.shop.update_in_db`)
    pass on. Checked where they are used (:func:`update`), not here.

    Attributes:
        engine: a registered engine (``zoa``, ``sdm``, ``spectral``).
        samples: posterior samples (SMC particles).
        seed: the sampler's seed (same seed, same posterior).
        sampler: ``auto`` | ``delayed`` | ``plain``.
        engine_options: the engine's discretisation for the whole update (``None``: the engine's own choice).
    """

    engine: str = "zoa"
    samples: int = 4000
    seed: int = 0
    sampler: str = "auto"
    engine_options: dict | None = None

    def keywords(self) -> dict:
        """The settings as :func:`update`'s keywords."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


def update(cfg: Config, cuts, points=None, *, engine: str = "zoa", samples: int = 4000,
           seed: int = 0, start=None, progress: Progress | None = None, client=None, sampler: str = "auto",
           stickout_mm=None, engine_options: dict | None = None):
    """The posterior of the modal parameters given labelled cuts (``cuts`` and the boundary ``points``: anything
    :func:`millstab.api.points` reads, a DataFrame included; :func:`millstab.update.update`); a
    measured-FRF config's prior centres on its fitted modes; ``start``: an earlier posterior whose cuts are
    among ``cuts`` (sequential reuse: only the new cuts are tempered in); ``client``: a ``distributed.Client``
    whose cluster runs the likelihood's engine calls where that pays (same seed, same posterior); ``sampler``:
    ``auto`` | ``delayed`` | ``plain`` (delayed acceptance screened by the zero-order engine, the default for
    every engine but zoa; the posterior is the chosen engine's either way, :data:`millstab.update.SAMPLERS`);
    ``stickout_mm``: the tool's stickout [mm] of each row of ``cuts`` (NaN: the config's; default the cuts'
    ``stickout_mm`` column, :func:`millstab.io.stickout.stickouts`, if they have one). A ``[tool]`` +
    ``[holder]`` config whose holder is given by modes is updated over the holder (one posterior for every
    stickout: :mod:`millstab.update.stickout`; decide at another stickout with :func:`at_stickout`);
    ``engine_options``: the engine's discretisation for the whole update, e.g. ``{"steps": 40}`` for sdm
    (:func:`millstab.forward.engine_options`), kept in the posterior for its decisions (:func:`with_engine_options`
    overrides them).

    The result's ``warnings`` hold every message for the user, one line each: data that lean on the
    prior, the prior–data conflict ("the cuts contradict the hammer test: …", :mod:`millstab.update.conflict`)
    and a bimodal exchange split; ``to_json()["warning_codes"]`` gives their codes. A door shows them all.

    Raises:
        InputError: fewer than 100 samples, bad cuts (see :class:`millstab.update.Evidence`), bad prior.
        Cancelled: raised by ``progress``.
    """
    from millstab.update import update as run_update

    check_samples(samples)  # 100..10^6 and what this machine's memory holds, before any allocation
    cfg = config(cfg)  # a Config, a file, "example:NAME" or its tables
    cuts = point_set(cuts, "cuts")  # a PointSet, a file, or a notebook's table (DataFrame, list of rows)
    points = None if points is None else point_set(points, "points")
    check_cuts(len(cuts) + (0 if points is None else len(points)))
    check_seed(seed)
    from millstab.update.stickout import over_holder

    if not over_holder(cfg):  # a prior over the holder needs no tip modes
        cfg, _ = modal(cfg)
    if stickout_mm is None:
        from millstab.io.stickout import stickouts

        stickout = stickouts(cuts)  # [m], or None without the column
    else:
        stickout = np.asarray(stickout_mm, dtype=float) * 1e-3
    if stickout is not None and over_holder(cfg):  # the tool's rule, row by row (a stickout under its fluted length)
        from millstab.update.stickout import check_stickouts_mm

        where = getattr(getattr(cuts, "source", None), "name", "cuts")
        check_stickouts_mm(np.asarray(stickout, float) * 1e3, f"{where} row {{row}}, stickout_mm", cfg.tooltip[0])
    if client is not None:  # a wrong client fails before any work
        from millstab.cluster import check_client

        check_client(client)
    post = run_update(cfg, cuts, points, engine=engine, samples=samples, seed=seed, start=start, progress=progress,
                      client=client, sampler=sampler, stickout=stickout, engine_options=engine_options)
    return dataclasses.replace(post, provenance={"config": cfg.name})  # in its JSON: the same from every door


def check_engine_options(engine: str, options: dict | None, field: str = "--engine-option") -> dict:
    """The engine's discretisation ``options`` checked before any work (keywords of the engine, values in range:
    :func:`millstab.forward.engine_options`); ``{}`` for none.

    Raises:
        InputError: naming ``field``, the keyword (and its value) and the keywords the engine takes.
    """
    from millstab.forward import engine_options

    return dict(engine_options(engine, options, field))


#: what an engine option is written as, in the doors' help and their errors
ENGINE_OPTION_FORM = "KEY=VALUE with a number, e.g. steps=40 (sdm: steps, fn_max_hz; spectral: nodes, near; zoa: none)"


def engine_option_pairs(texts, field: str = "--engine-option") -> dict:
    """Engine options as written, ``["steps=40", "fn_max_hz=3e3"]`` (the repeatable ``--engine-option``, or the
    app's field split at commas), as a table ``{"steps": 40, "fn_max_hz": 3000.0}``: a whole number as int,
    another number as float, anything else kept as text for :func:`check_engine_options` to refuse by name.

    Raises:
        InputError: naming ``field``: a text without ``=``, an empty keyword or value, a keyword given twice.
    """
    out: dict = {}
    for text in texts or ():
        key, eq, value = (part.strip() for part in str(text).partition("="))
        if not eq or not key or not value:
            raise InputError(field, text, ENGINE_OPTION_FORM)
        if key in out:
            raise InputError(field, text, f"each keyword once ({key} = {out[key]} already)")
        out[key] = _number(value)
    return out


def _number(text: str):
    """``"40"`` → 40, ``"0.5"``/``"1e3"`` → float, anything else: the text itself."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def engine_options_from_text(engine: str, text: str | None, field: str = "engine options") -> dict:
    """The app's engine-options field, ``"steps=10"`` or ``"nodes=8, near=0.5"`` (commas or semicolons between
    the options; empty: the engine's own choice, ``{}``), read by :func:`engine_option_pairs` and checked by
    :func:`check_engine_options` for ``engine``: the same rules and the same one-line errors as ``--engine-option``.

    Raises:
        InputError: naming ``field``, the keyword (and its value) and the keywords the engine takes.
    """
    texts = [t.strip() for t in str(text or "").replace(";", ",").split(",") if t.strip()]
    return check_engine_options(engine, engine_option_pairs(texts, field), field)


def engine_keywords(engine: str) -> str:
    """"the sdm engine's discretisation keywords: fn_max_hz, steps": what :func:`check_engine_options` names in its
    errors (the keywords of the engine's ``envelope_batch``, :func:`millstab.forward.option_keywords`), for a door
    to show before any error."""
    from millstab.forward import option_keywords

    return option_keywords(engine)[1]


def engine_update_note(engine: str) -> str:
    """One line for a door that lets the user pick the update's engine: what it models, what an update with it
    costs (figures of docs/updating.md, measured on the 2-core build machine) and its option keywords.

    Raises:
        InputError: an engine that is not registered.
    """
    from millstab.stability import get_engine

    e = get_engine(engine)
    keys = engine_keywords(engine)
    if getattr(e, "time_averaged", False):
        return (f"{engine}: the zero-order (time-averaged) model: fast, an update of 1 000 samples in seconds, but "
                f"poor at low radial immersion (a/D below ~0.2); {keys}")
    return (f"{engine}: interrupted cutting, right at low radial immersion too, but slow: each update move is "
            f"screened by the zero-order engine and the survivors computed by {engine} (delayed acceptance), "
            f"10-50x the zero-order update's CPU, and the map and recommendation call {engine} for every sample: "
            f"start with a few hundred samples and a coarse discretisation; {keys}")


def with_engine_options(post, options: dict | None, field: str = "--engine-option"):
    """The posterior ``post`` deciding (map, recommend, next test, predict) with the engine options ``options``
    over those it was fitted with (:meth:`millstab.update.Posterior.with_engine_options`; ``None``: ``post``).

    Raises:
        InputError: as :func:`check_engine_options`, for ``post.engine``.
    """
    return post.with_engine_options(options, field)


def over_holder(cfg) -> bool:
    """Whether the config's prior is over a holder (``[tool]`` + ``[holder]`` with holder modes: one
    posterior for every stickout, docs/tooltip.md) rather than over the tool tip's modes."""
    from millstab.update.stickout import over_holder as holder

    return holder(cfg)


def at_stickout(post, stickout_mm: float | None):
    """The posterior ``post`` (over a holder) with the tool at ``stickout_mm`` [mm] for map, recommend and
    predict (``None``: ``post`` itself); InputError for a posterior over tip modes or a bad stickout."""
    from millstab.update.stickout import at_stickout as move
    from millstab.update.stickout import check_stickout_mm, warn_outside_stickouts

    if stickout_mm is None:
        return post
    # the tool's own rule (no shorter than its fluted length: 0.06 mm, metres written as mm, crashed the beam model)
    s = check_stickout_mm(stickout_mm, "--stickout", getattr(post.prior.par, "tool", None))
    moved = move(post, s * 1e-3)  # refuses a posterior over the tip's modes first
    warn_outside_stickouts(post, s, stacklevel=2)  # as the speed range beyond the cuts' is warned
    return moved


def posterior_from_json(doc, source: str = "posterior"):
    """A :class:`millstab.update.Posterior` from its JSON document (``millstab update --out``)."""
    from millstab.update import Posterior

    return Posterior.from_json(doc, str(source))


def cuts_in_condition(post, cuts: PointSet, base) -> tuple[PointSet, int]:
    """(the cuts made in the condition ``post`` decides for, how many were made in others): what a map of that
    condition may draw; ``base`` (the config's cutting) fills the cuts' empty condition cells."""
    from millstab.points import in_condition

    mask = in_condition(cuts, base, post.condition, post.diameter_mm)
    return cuts.subset(mask), int((~mask).sum())


def for_condition(post, *, radial_immersion: float | None = None, milling: str | None = None,
                  entry_deg: float | None = None, exit_deg: float | None = None, teeth: int | None = None,
                  radial_width_mm: float | None = None):
    """The posterior deciding for a target cutting condition (map, recommend, predict): the options as the
    doors name them (``--radial-immersion``, ``--milling``, ``--entry-deg``/``--exit-deg``, ``--teeth``,
    ``--radial-width`` with the config's diameter); what is not given keeps the posterior's condition
    (the config's). A posterior without a tool diameter takes a width for nothing here (recommend's width is then
    for the rate in cm³/min alone). None given: ``post`` itself. Rules and errors: :func:`target_condition`."""
    if post.diameter_mm is None:
        radial_width_mm = None
    c = target_condition(post.condition, post.diameter_mm, radial_immersion=radial_immersion, milling=milling,
                         entry_deg=entry_deg, exit_deg=exit_deg, teeth=teeth, radial_width_mm=radial_width_mm)
    return post if c is None else post.for_condition(c)


def target_condition(base, diameter_mm: float | None = None, *, radial_immersion: float | None = None,
                     milling: str | None = None, entry_deg: float | None = None, exit_deg: float | None = None,
                     teeth: int | None = None, radial_width_mm: float | None = None):
    """The cutting condition the doors' target options name (``--radial-immersion``, ``--milling``,
    ``--entry-deg``/``--exit-deg``, ``--teeth``, ``--radial-width`` with the tool's ``diameter_mm``), ``base`` (a
    :class:`~millstab.model.Cutting`, the config's or the posterior's) with what is given replaced; ``None`` when
    nothing is given. Rules: :func:`millstab.points.condition_of`. With a diameter a width sets a/D = width/D
    (with ``milling`` or the base's direction) or, given with a/D or the angles, must agree with them
    (:func:`millstab.points.radial_width`, within :data:`millstab.points.WIDTH_TOL` of D) and they decide.

    Raises:
        InputError: naming the option: a/D outside (0, 1], milling not up|down, angles outside [0, 180] deg
            or entry ≥ exit, teeth not a positive integer, angles together with a/D or milling, a width outside
            (0, D] or contradicting a/D or the angles (naming both), a width without a diameter.
    """
    from millstab.points import MILLING_RULE, condition_of, milling_word

    given = {k: v for k, v in (("--radial-immersion", radial_immersion), ("--milling", milling),
                               ("--entry-deg", entry_deg), ("--exit-deg", exit_deg), ("--teeth", teeth),
                               ("--radial-width", radial_width_mm)) if v is not None}
    if not given:
        return None
    if radial_immersion is not None and not (np.isfinite(radial_immersion) and 0 < radial_immersion <= 1):
        pct = (f"; a percentage? {radial_immersion:g} % is {radial_immersion / 100:g}"
               if np.isfinite(radial_immersion) and 1 < radial_immersion <= 100 else "")
        raise InputError("--radial-immersion", radial_immersion, f"the radial immersion a/D, in (0, 1] (1 = slot){pct}")
    if milling is not None:
        if milling_word(milling) not in ("up", "down"):
            raise InputError("--milling", milling, MILLING_RULE)
        milling = milling_word(milling)
    for opt, a in (("--entry-deg", entry_deg), ("--exit-deg", exit_deg)):
        if a is not None and not (np.isfinite(a) and 0 <= a <= 180):
            raise InputError(opt, a, "an angle in [0, 180] deg")
    if (entry_deg is None) != (exit_deg is None):
        raise InputError("--entry-deg" if exit_deg is None else "--exit-deg",
                         entry_deg if exit_deg is None else exit_deg, "give --entry-deg and --exit-deg together")
    if entry_deg is not None and entry_deg >= exit_deg:
        raise InputError("--entry-deg", entry_deg, f"less than --exit-deg ({exit_deg:g})")
    if radial_width_mm is not None and diameter_mm is not None:  # a width as a/D, or checked against a/D or angles
        radial_width_mm = _width_of(radial_width_mm, diameter_mm, radial_immersion, entry_deg, exit_deg)
    if entry_deg is not None and (radial_immersion is not None or milling is not None or radial_width_mm is not None):
        raise InputError("--entry-deg", entry_deg, "give --entry-deg/--exit-deg or --radial-immersion with --milling, "
                                                   "not both")
    if radial_immersion is not None and radial_width_mm is not None:
        raise InputError("--radial-width", radial_width_mm, "give --radial-immersion or --radial-width, not both")
    if teeth is not None and not (isinstance(teeth, (int, np.integer)) and teeth >= 1):
        raise InputError("--teeth", teeth, "a positive integer")
    return condition_of(base, radial_immersion=radial_immersion, radial_width_mm=radial_width_mm,
                        milling=None if milling is None else str(milling).strip().lower(), entry_deg=entry_deg,
                        exit_deg=exit_deg, teeth=teeth, diameter_mm=diameter_mm, field="target condition")


def _width_of(width_mm: float, diameter_mm: float, radial_immersion: float | None, entry_deg: float | None,
              exit_deg: float | None) -> float | None:
    """``--radial-width`` on a tool of ``diameter_mm``: the width itself when it alone names the condition, ``None``
    when it agrees with the a/D or angles given (they decide).

    Raises:
        InputError: the width outside (0, D], or more than :data:`millstab.points.WIDTH_TOL` · D off the a/D or
            angles (naming both).
    """
    import math

    from millstab.points import WIDTH_TOL, radial_width

    if not (np.isfinite(width_mm) and 0 < width_mm <= diameter_mm * (1 + 1e-12)):
        raise InputError("--radial-width", width_mm,
                         f"a radial width in (0, {diameter_mm:g}] mm (the tool diameter of the config)")
    if radial_immersion is not None:
        other, implied = f"--radial-immersion {radial_immersion:g}", radial_immersion * diameter_mm
    elif entry_deg is not None and exit_deg is not None:
        other = f"--entry-deg {entry_deg:g}/--exit-deg {exit_deg:g}"
        implied = radial_width(math.radians(entry_deg), math.radians(exit_deg), diameter_mm)
    else:
        return width_mm
    if abs(width_mm - implied) > WIDTH_TOL * diameter_mm:
        raise InputError("--radial-width", width_mm,
                         f"contradicts {other}: that is a width of {implied:.4g} mm on the {diameter_mm:g} mm tool "
                         "of the config; give one of them, or both in agreement")
    return None


def condition_line(post) -> str:
    """"computed for a/D 0.25 up milling, 4 teeth" (and whether the cuts were made in it) for the doors."""
    from millstab.points import condition_text, never_cut_note, same_condition

    trained = post.trained_conditions
    seen = any(same_condition(c, post.condition) for c in trained)
    note = "a condition of the cuts" if seen else never_cut_note(trained)
    from millstab.update.stickout import stickout_mm_of

    so = stickout_mm_of(post)  # a posterior over the holder decides at one stickout: say which
    return f"computed for {condition_text(post.condition)}{'' if so is None else f', stickout {so:g} mm'} ({note})"


def next_test_elsewhere(rec) -> str | None:
    """The condition of ``rec``'s next test as a line ("a/D 0.2 down milling, 2 teeth") when it is not the
    decision's (a test in another condition can teach the shared parameters more: its ``why`` says so), else
    ``None``: the doors then must not draw it on the decision's map as if it were there."""
    nt, here = rec.next_test.get("condition"), rec.computed_for
    if not nt or not here:
        return None
    if (nt.get("teeth") == here.get("teeth") and abs(nt.get("entry_deg", 0) - here.get("entry_deg", 0)) < 1e-3
            and abs(nt.get("exit_deg", 0) - here.get("exit_deg", 0)) < 1e-3):
        return None
    from millstab.points import described_text

    return described_text(nt)


def depth_grid(max_mm: float, n: int = 100, field: str = "--max-depth") -> np.ndarray:
    """``n`` depths evenly spaced up to ``max_mm`` [mm]: max/n, 2·max/n, …, max (a P(stable) map's axis).

    Raises:
        InputError: ``max_mm`` not a finite number > 0, or ``n`` < 2.
    """
    if isinstance(max_mm, bool) or not isinstance(max_mm, (int, float, np.number)) or not (np.isfinite(max_mm)
                                                                                           and max_mm > 0):
        raise InputError(field, max_mm, "must be a depth > 0 mm")  # "5" too: numpy's TypeError before
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError("depths", n, "need a whole number of at least 2 depths")
    return np.arange(1, n + 1) * (max_mm / n)


def p_stable(post, rpm: np.ndarray, depth_mm: np.ndarray, client=None, *, samples: int | str | None = "auto",
             seed: int = 0, memo=None) -> np.ndarray:
    """P(stable) on the grid rpm × depth (S, D); warns where the speeds reach beyond the tested ones;
    ``client``: the samples' limits on its Dask cluster where that pays (same numbers); ``samples``: ``"auto"``
    (every sample from the cheapest engine, a seeded subsample of ``decide.MAP_SAMPLES`` from the others:
    :func:`map_samples`), ``"all"``/``None``, or from a seeded subsample of that many posterior samples
    (``millstab.update.decide.p_stable_map``: each cell's Monte Carlo standard error is at most ½/√samples; say it
    with :func:`map_samples_text`). ``memo``: a ``millstab.update.decide.LimitMemo`` shared with a recommendation from
    the same posterior (:func:`recommend` ``memo=``): the limits they share (the map's subsample holds the fast
    search's, at the speeds both read) are computed once; the same numbers.

    Raises:
        InputError: more than :data:`MAX_MAP_CELLS` cells; a speed that is not a finite number > 0, a depth that is
            not one ≥ 0 [mm]; a bad seed.
    """
    from millstab.stability import check_rpm
    from millstab.update import p_stable_map
    from millstab.update.decide import warn_outside

    m = map_samples(post, samples)
    check_seed(seed)
    rpm, depth_mm = check_rpm(rpm), _depths(depth_mm)  # a NaN depth made P(stable) -6 .. 0 before

    if np.size(rpm) * np.size(depth_mm) > MAX_MAP_CELLS:
        raise InputError("--depth", f"{np.size(depth_mm)} depths",
                         f"{np.size(rpm)} speeds × {np.size(depth_mm)} depths is too many cells (max "
                         f"{MAX_MAP_CELLS:.0e})")
    warn_outside(post, float(np.min(rpm)), float(np.max(rpm)), stacklevel=3)
    if client is not None:
        from millstab.cluster import check_client

        check_client(client)
    return p_stable_map(post, rpm, depth_mm, client, samples=m, seed=seed, memo=None if client is not None else memo)


def _depths(depth_mm, field: str = "depth_mm") -> np.ndarray:
    """The map's depths as a non-empty 1-D float array [mm]; InputError naming ``field`` and the first value that is
    not a finite number ≥ 0 (a depth 0, a grid from np.linspace(0, …), is stable: no cut)."""
    try:
        d = np.atleast_1d(np.asarray(depth_mm, dtype=float))
    except (TypeError, ValueError):
        raise InputError(field, depth_mm, "depths must be a non-empty 1-D list of numbers in mm") from None
    if d.ndim != 1 or d.size == 0:
        raise InputError(field, depth_mm, "depths must be a non-empty 1-D list of numbers in mm")
    bad = ~(np.isfinite(d) & (d >= 0))
    if bad.any():
        raise InputError(field, float(d[bad][0]), "depths must be finite numbers >= 0 mm")
    return d


def limit_memo():
    """A store of limits for a map and a recommendation from one posterior (:func:`p_stable` and :func:`recommend`
    ``memo=``; ``millstab.update.decide.LimitMemo``)."""
    from millstab.update.decide import LimitMemo

    return LimitMemo()


def map_samples(post, samples: int | str | None = "auto") -> int | None:
    """The posterior samples :func:`p_stable` reads for ``post`` (``None``: every one;
    :func:`millstab.update.decide.map_samples`). Raises InputError (``--samples``) for a bad value."""
    from millstab.update.decide import map_samples as resolve

    return resolve(post.engine, post.samples.shape[0], samples)


def map_samples_text(post, samples: int | str | None = "auto") -> str:
    """What a map of ``post`` says of the samples it read ("500 of 1000 samples (Monte Carlo standard error ≤ 0.022
    per cell)")."""
    from millstab.update.decide import map_samples_text as text

    return text(map_samples(post, samples), post.samples.shape[0])


def map_table(rpm: np.ndarray, depth_mm: np.ndarray, pm: np.ndarray) -> tuple[list[str], list]:
    """(header, columns) of the map CSV rpm,depth_mm,p_stable (speed-major)."""
    R, D = np.meshgrid(rpm, depth_mm, indexing="ij")
    return ["rpm", "depth_mm", "p_stable"], [R.ravel(), D.ravel(), pm.ravel()]


def map_figure(post, rpm: np.ndarray, depth_mm: np.ndarray, pm: np.ndarray, title: str = "P(stable)"):
    """The P(stable) map with its 5/50/95 % boundaries, the prior's SLD and the cuts made in the posterior's
    condition (the decision's: those in other conditions are counted in the legend, not drawn; ``millstab map
    --plot``); titled ``title`` and the condition, as an SLD is (:func:`millstab.api.sld_title`): "P(stable) from
    post.json: a/D 0.5 down milling, 2 teeth"."""
    from millstab.plot.update import plot_pmap
    from millstab.stability import get_engine

    par = post.prior.par  # the prior median's tip (over a holder: the tip at the posterior's stickout)
    if post.engine_options:  # the discretisation of the posterior's decisions (the engine's envelope may lack some)
        from millstab.forward import forward

        prior_sld = forward(par, post.prior.cutting, post.engine, options=post.engine_options)(par.theta0, rpm)[0] * 1e3
    else:
        prior_sld = get_engine(post.engine).envelope(par.structure(par.theta0), post.prior.cutting, rpm).depth_mm
    drawn = post.cuts_in_condition()  # a cut in another condition belongs to another boundary
    elsewhere = len((post.cuts or {}).get("rpm") or []) - len(drawn.get("rpm") or [])
    return plot_pmap(rpm, depth_mm, pm, rpm, prior_sld, drawn, title=f"{title}: {condition_text(post.condition)}",
                     elsewhere=elsewhere)


def corner_figure(post):
    """The pair plot of the posterior samples (``millstab update --plot``)."""
    return post.figure()


#: = millstab.update.decide.TEST_RISK (not imported: a door checks its options before numba loads; a test checks)
TEST_RISK = 0.5


def decision_rule(risk: float, rpm: str, *, confidence: str | float | None = 0.9, speed_tolerance: float = 0.0,
                  test_risk: float = TEST_RISK, **rule) -> tuple[tuple[float, float], dict]:
    """The options of a recommendation as written, checked before any posterior is read (the cheapest errors
    first): ``risk`` in (0, 1), ``rpm`` ``LOW:HIGH``, ``confidence`` in [0.5, 1) or ``"none"``, ``speed_tolerance``
    in [0, 0.1), ``test_risk`` in (0, 1]. Returns ((low, high) [rpm], the keywords of :func:`recommend`: these
    and ``rule``, e.g. ``max_depth_mm``, ``width_mm``, ``feed_mm``, ``seed``).

    Raises:
        InputError: naming the option (``--risk``, ``--rpm``, ``--confidence``, ``--speed-tolerance``, ``--test-risk``,
            ``--confirm``, ``--discriminate``, ``--search``).
    """
    import math

    from millstab.parsing import parse_interval

    risk = check_risk(risk)
    span = parse_interval(rpm, "--rpm", "rpm", positive=True)
    if isinstance(confidence, str):
        text = confidence
        try:
            confidence = None if text.strip().lower() == "none" else float(text)
        except ValueError:
            confidence = math.nan
        if confidence is not None and not 0.5 <= confidence < 1:
            raise InputError("--confidence", text, "a one-sided confidence in [0.5, 1), e.g. 0.9, or 'none'")
    if not (math.isfinite(speed_tolerance) and 0 <= speed_tolerance < 0.1):
        raise InputError("--speed-tolerance", speed_tolerance,
                         "a relative spindle-speed error in [0, 0.1), e.g. 0.0025")
    if not (math.isfinite(test_risk) and 0 < test_risk <= 1):
        raise InputError("--test-risk", test_risk, f"the next test's tolerated probability of chatter, in (0, 1], e.g. "
                                                   f"{TEST_RISK:g} (1: no cap)")
    from millstab.update import decide

    for key, default, choices in (("confirm", decide.CONFIRM, decide.CONFIRM_CHOICES),
                                  ("discriminate", decide.DISCRIMINATE, decide.DISCRIMINATE_CHOICES),
                                  ("search", "auto", decide.SEARCH_CHOICES)):
        if rule.get(key, default) not in choices:
            raise InputError(f"--{key}", rule[key], "one of " + ", ".join(choices))
    return span, dict(rule, confidence=confidence, speed_tolerance=speed_tolerance, test_risk=test_risk)


def recommend(post, risk: float, rpm_range: tuple[float, float], *, max_depth_mm: float | None = None,
              width_mm: float | None = None, feed_mm: float | None = None, seed: int = 0, **rule):
    """The most productive cut with P(chatter) ≤ ``risk`` in ``rpm_range`` [rev/min], and the next test
    (:func:`millstab.update.recommend`; ``rule``: its ``confidence``, ``speed_tolerance``, ``coarse_points``,
    ``search`` and ``memo`` (limits shared with a map: :func:`p_stable`), defaults there).

    Raises:
        InputError: risk outside (0, 1), a bad speed range, a depth cap ≤ 0, a bad confidence or tolerance.
    """
    from millstab.update import recommend as run_recommend

    check_seed(seed)
    try:
        low, high = (float(v) for v in rpm_range)
    except (TypeError, ValueError):  # (5000,), "5000:8000", ("5000", "x"): numpy's unpacking error before
        raise InputError("--rpm", rpm_range, "a speed range (LOW, HIGH) of two numbers in rev/min") from None
    return run_recommend(post, risk, (low, high), max_depth_mm=max_depth_mm, width_mm=width_mm, feed_mm=feed_mm,
                         seed=seed, **rule)
