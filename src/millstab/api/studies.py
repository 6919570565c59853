"""Virtual cuts, modal fits of tap tests and the paper's reproduction as services."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from millstab.progress import Progress
from millstab.errors import InputError
from millstab.config import Config
from millstab.points import PointSet
from millstab.warnlog import warn


def _feed(feed_mm: float) -> float:
    if not (np.isfinite(feed_mm) and feed_mm > 0):
        raise InputError("--feed-per-tooth", feed_mm, "must be a number > 0 mm")
    return feed_mm * 1e-3


def config_feed_mm(cfg: Config, feed_mm: float | None = None) -> float:
    """The feed per tooth [mm]: ``feed_mm`` when given, else the config's ``feed_per_tooth``, else 0.1 mm."""
    if feed_mm is not None:
        return feed_mm
    return cfg.feed_per_tooth_m * 1e3 if getattr(cfg, "feed_per_tooth_m", None) else 0.1


def simulate_mode(*, cuts=None, rpm: float | None = None, depth: float | None = None, plot=None, record=None,
                  marginal: str = "keep", label_noise: float = 0.0, seed: int | None = None, record_tap=None) -> str:
    """Which simulation the options of ``millstab simulate`` ask for: ``"cuts"`` (label a file of cuts,
    :func:`label_cuts`) or ``"one"`` (one cut at ``rpm`` [rev/min] and ``depth`` [mm], :func:`simulate_cut`),
    checked before any work.

    Raises:
        InputError: a combination of options that one mode does not take (named), a ``record`` or ``record_tap``
            file that is not .wav or .csv, or ``marginal`` not ``keep``/``random``.
    """
    from pathlib import Path

    for opt, given in (("--record", record), ("--record-tap", record_tap)):
        if given is not None and Path(given).suffix.lower() not in (".wav", ".csv"):
            raise InputError(opt, str(given), "a .wav or .csv file")
    if marginal not in ("keep", "random"):
        raise InputError("--marginal", marginal, "keep or random")
    if cuts is not None:
        if rpm is not None or depth is not None:
            raise InputError("--cuts", str(cuts), "give either --cuts or --rpm/--depth, not both")
        for opt, given in (("--plot", plot), ("--record", record), ("--record-tap", record_tap)):
            if given is not None:
                raise InputError(opt, str(given), f"{opt} is for one cut (--rpm/--depth), not for --cuts")
        return "cuts"
    if rpm is None or depth is None:
        raise InputError("--rpm/--depth", f"{rpm}/{depth}",
                         "give the speed (rev/min) and depth (mm) of one cut, or --cuts FILE")
    for opt, bad in (("--label-noise", label_noise != 0.0), ("--marginal", marginal != "keep")):
        if bad:
            raise InputError(opt, label_noise if opt == "--label-noise" else marginal, f"{opt} applies to --cuts only")
    if seed is not None and record is None and record_tap is None:
        raise InputError("--seed", seed, "the seed applies to --cuts (label noise) or --record/--record-tap (sensor "
                         "noise)")
    return "one"


def _modal_for_simulation(cfg: Config) -> Config:
    """``cfg`` with modes (the time-domain model needs fn, k, ζ per mode): a measured FRF's or a [tool] + [holder]
    config's computed tip FRF fitted first, said in a warning (:func:`millstab.api.modal`; an exploratory user's
    tool config was refused with "structure = 'measured FRF'", pointing nowhere)."""
    from millstab.api.inputs import modal

    fitted, note = modal(cfg)
    if note:
        warn(note, UserWarning, stacklevel=3)
    return fitted


def simulate_cut(cfg: Config, rpm: float, depth_mm: float, *, feed_mm: float | None = None, revs: float = 100.0,
                 steps: int | None = None, start: str = "steady"):
    """One time-domain cut at ``rpm`` [rev/min] and ``depth_mm`` [mm] and its label: (CutResult, Detection);
    ``feed_mm`` None: :func:`config_feed_mm`."""
    from millstab.bounds import check_speeds
    from millstab.simulate import detect
    from millstab.simulate import simulate_cut as run

    from millstab.api.inputs import config

    cfg = config(cfg)  # a Config, a file, "example:NAME" or its tables
    feed_mm = config_feed_mm(cfg, feed_mm)
    check_speeds(rpm, "--rpm")  # a near-zero speed is days of steps: refused before the work
    cfg = _modal_for_simulation(cfg)
    res = run(cfg.structure, cfg.cutting, rpm, depth_mm * 1e-3, _feed(feed_mm), revs=revs, steps_per_tooth=steps,
              start=start)
    return res, detect(res)


def label_cuts(cfg: Config, cuts: PointSet, *, feed_mm: float | None = None, revs: float = 100.0,
               steps: int | None = None, start: str = "steady", label_noise: float = 0.0, marginal: str = "keep",
               seed: int | None = None):
    """Simulate and label the cuts (:class:`millstab.simulate.Labels`: stable | marginal | chatter, chatter Hz),
    each in its own cutting condition and feed: the cuts' condition columns (radial_immersion, milling,
    entry_deg/exit_deg, teeth, feed_per_tooth_mm; :func:`millstab.points.cut_conditions`), empty cells taking
    the config's; ``feed_mm`` None: the config's ``feed_per_tooth``, else 0.1 mm. One compiled, parallel batch
    per distinct (condition, feed); the label noise is drawn in cut order after all of them (same seed, same
    labels however the cuts group)."""
    from millstab.bounds import seed as check_seed
    from millstab.points import cut_conditions, cut_feeds
    from millstab.simulate import Labels, add_label_noise
    from millstab.simulate import label_cuts as run

    from millstab.api.inputs import config
    from millstab.api.inputs import points as point_set

    check_seed(seed)
    cfg, cuts = config(cfg), point_set(cuts, "cuts")  # each as every task takes it
    feed_mm = config_feed_mm(cfg, feed_mm)
    _feed(feed_mm)
    cfg = _modal_for_simulation(cfg)
    conds, idx = cut_conditions(cuts, cfg.cutting, getattr(cfg, "diameter_mm", None))
    feeds = cut_feeds(cuts, feed_mm)
    groups = np.unique(np.c_[idx, feeds], axis=0) if len(cuts) else np.zeros((0, 2))
    if len(groups) <= 1:  # one condition and feed: one batch, the labels as ever
        c = conds[0] if len(conds) else cfg.cutting
        return run(cfg.structure, c, cuts.rpm, cuts.depth_m, _feed(float(feeds[0]) if len(cuts) else feed_mm),
                   revs=revs, steps_per_tooth=steps, start=start, label_noise=label_noise, marginal=marginal, seed=seed)
    if not 0.0 <= label_noise < 0.5:
        raise InputError("label_noise", label_noise, "must be a probability in [0, 0.5)")
    if (label_noise > 0 or marginal == "random") and seed is None:
        raise InputError("seed", seed, "label noise needs a seed (an integer), so runs can be repeated")
    parts = []
    for k, f in groups:  # a handful of conditions, each a compiled parallel batch
        rows = np.flatnonzero((idx == k) & (feeds == f))
        parts.append((rows, run(cfg.structure, conds[int(k)], cuts.rpm[rows], cuts.depth_m[rows], _feed(float(f)),
                                revs=revs, steps_per_tooth=steps, start=start)))
    n = len(cuts)

    def gather(name, dtype):
        out = np.empty(n, dtype=dtype)
        for rows, lab in parts:
            out[rows] = getattr(lab, name)
        return out

    true = gather("true_label", "<U8")
    return Labels(cuts.rpm.copy(), cuts.depth_m.copy(), add_label_noise(true, label_noise, marginal, seed), true,
                  gather("chatter_hz", float), gather("lobe", "<U4"), gather("level", float), gather("growth", float),
                  seed, gather("multiplier", float))


def labels_table(labels, cuts: PointSet | None = None) -> tuple[list[str], list]:
    """(header, columns) of a labelled-cuts CSV rpm,depth_mm,label,chatter_hz (a cuts file for ``update``; the
    frequency to 0.1 Hz), and what else ``cuts`` carries as read: its weights (where any is not 1), batches (where
    any is given), condition columns (so the labelled file keeps each cut's condition) and extra columns (a shop's
    notes, feed, tool number: kept, as ``update`` keeps them). With ``cuts``, its speeds and depths are written as
    read: the labels carry depths in m, and 3.34 mm through m and back is 3.3400000000000003 mm in the user's file."""
    from millstab.io.points import condition_columns

    header, cols = labels.table()
    header, cols = list(header), list(cols)
    # the detector reads a peak of a spectrum with lines f_T/64 apart: 0.1 Hz is all the file can honestly hold
    cols[header.index("chatter_hz")] = np.round(np.asarray(cols[header.index("chatter_hz")], float), 1)
    if cuts is not None:
        cols[0], cols[1] = cuts.rpm, cuts.depth_mm
        if (np.asarray(cuts.weight) != 1.0).any():
            header, cols = header + ["weight"], cols + [cuts.weight]
        if (np.asarray(cuts.batch) != "").any():
            header, cols = header + ["batch"], cols + [list(cuts.batch)]
        h, c = condition_columns(cuts)
        header, cols = header + h, cols + c
        taken = set(header)
        for name, col in cuts.extra.items():
            if name not in taken:  # a column the labelling writes itself (a plan's own chatter_hz) is the new one
                header, cols = header + [name], cols + [list(col)]
    return header, cols


def modal_fit(frf_x, frf_y=None, *, band: str | None = None, modes: str | int | None = None,
              records: tuple[int | None, int | None] = (None, None), frf_type: str = "auto"):
    """Modes fitted to measured drive-point FRF files (:class:`millstab.modal.run.ModalResult`); ``frf_type``:
    what the files hold, ``auto`` (detected; mobility/accelerance refused with the conversion), ``receptance``,
    ``mobility`` or ``accelerance`` (converted)."""
    from millstab.modal.run import fit_files, parse_band, parse_modes

    return fit_files(frf_x, frf_y, band=parse_band(band), modes=parse_modes(modes), records=records,
                     frf_type=frf_type)


def check_frf_type(frf_type: str) -> str:
    """``--frf-type`` checked before any file is read: ``auto``, ``receptance``, ``mobility`` or ``accelerance``."""
    from millstab.modal.run import check_frf_type as check

    return check(frf_type)


def modal_check(result, cfg: Config, rpm: np.ndarray, frf_x, frf_y=None, *, band: str | None = None,
                records: tuple[int | None, int | None] = (None, None), frf_type: str = "auto"):
    """The SLD check of a modal fit (:class:`millstab.modal.run.SLDCheck`): the zero-order boundary of the
    fitted modes beside that of the measured FRF files themselves, under ``cfg``'s cutting conditions at
    ``rpm`` [rev/min] (minimum depths [mm], worst relative difference and its speed)."""
    from millstab.modal.run import measured_structure, parse_band, sld_check

    measured = measured_structure(frf_x, frf_y, parse_band(band), records, frf_type)
    return sld_check(result.structure, measured, cfg.cutting, rpm)


def _modal_sources(result) -> dict[str, str]:
    return {d: fit.source for d, fit in result.fits.items()}


def modal_quality(result, check=None) -> dict:
    """The fit quality JSON of ``millstab modal --json`` (schema ``millstab.modal/1``), with the SLD check if run."""
    from millstab.modal.output import quality

    return quality(result, _modal_sources(result), check)


def modal_toml(result) -> str:
    """The ``[structure]`` section of the fitted modes (config units), with each mode's quality as a comment."""
    from millstab.modal.output import structure_toml

    return structure_toml(result, _modal_sources(result))


def modal_figure(result, check=None):
    """The fit, its phase, the stabilisation diagram (and the SLD check) as one matplotlib figure."""
    return result.figure(check=check)


def simulate_figure(result, detection, title: str = ""):
    """A simulated cut's trace, once-per-tooth map and spectrum as one matplotlib figure
    (:meth:`millstab.simulate.CutResult.figure` with its detection)."""
    return result.figure(detection=detection, title=title or None)


def reproduce_steps() -> list[str]:
    """The names of the reproduction's steps, in the order :func:`reproduce` runs them."""
    from millstab import reproduce as rp

    return [n for n, _ in rp.steps()]


def reproduce(out: str | Path, *, quick: bool = False, seed: int = 0, points: str | Path | None = None,
              progress: Progress | None = None):
    """Reproduce the seed paper's results into the folder ``out`` (:func:`millstab.reproduce.run`);
    ``progress(step name, steps done, steps in all)`` as each step starts (and once more at the end)."""
    from millstab import reproduce as rp

    total = len(rp.steps())
    seen: list[str] = []

    def step(name: str) -> None:
        if progress is not None:
            progress(name, len(seen), total)
        seen.append(name)

    rep = rp.run(Path(out), quick=quick, seed=seed, points=None if points is None else Path(points), progress=step)
    if progress is not None:
        progress("done", total, total)
    return rep
