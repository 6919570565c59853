"""Virtual cuts, modal fits of tap tests and the paper's reproduction as services."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from millstab.api.progress import Progress
from millstab.errors import InputError
from millstab.io.config import Config
from millstab.io.points import PointSet


def _feed(feed_mm: float) -> float:
    if not (np.isfinite(feed_mm) and feed_mm > 0):
        raise InputError("--feed-per-tooth", feed_mm, "must be a number > 0 mm")
    return feed_mm * 1e-3


def simulate_cut(cfg: Config, rpm: float, depth_mm: float, *, feed_mm: float = 0.1, revs: float = 100.0,
                 steps: int | None = None, start: str = "steady"):
    """One time-domain cut at ``rpm`` [rev/min] and ``depth_mm`` [mm] and its label: (CutResult, Detection)."""
    from millstab.bounds import check_speeds
    from millstab.simulate import detect, simulate_cut as run

    check_speeds(rpm, "--rpm")  # a near-zero speed is days of steps: refused before the work
    res = run(cfg.structure, cfg.cutting, rpm, depth_mm * 1e-3, _feed(feed_mm), revs=revs, steps_per_tooth=steps,
              start=start)
    return res, detect(res)


def label_cuts(cfg: Config, cuts: PointSet, *, feed_mm: float = 0.1, revs: float = 100.0, steps: int | None = None,
               start: str = "steady", label_noise: float = 0.0, marginal: str = "keep", seed: int | None = None):
    """Simulate and label the cuts (:class:`millstab.simulate.Labels`: stable | marginal | chatter, chatter Hz)."""
    from millstab.bounds import seed as check_seed
    from millstab.simulate import label_cuts as run

    check_seed(seed)
    return run(cfg.structure, cfg.cutting, cuts.rpm, cuts.depth_m, _feed(feed_mm), revs=revs, steps_per_tooth=steps,
               start=start, label_noise=label_noise, marginal=marginal, seed=seed)


def labels_table(labels) -> tuple[list[str], list]:
    """(header, columns) of a labelled-cuts CSV rpm,depth_mm,label,chatter_hz (a cuts file for ``update``)."""
    return labels.table()


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
    from millstab.plot.modal import plot_modal_fit

    return plot_modal_fit(result, check)


def simulate_figure(result, detection, title: str = ""):
    """A simulated cut's displacement, force and detection as one matplotlib figure."""
    from millstab.plot.simulate import plot_cut

    return plot_cut(result, detection, title=title)


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
