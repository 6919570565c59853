"""Identification and test planning as services: a fit from boundary points, its figures, and the
speeds of the next tests (around a prior or a fit)."""

from __future__ import annotations

import dataclasses
from typing import Mapping, Sequence

import numpy as np

from millstab.api.inputs import modal
from millstab.api.inputs import points as point_set
from millstab.progress import Progress, solver_progress
from millstab.errors import InputError
from millstab.identify import METHODS as IDENTIFY_METHODS  # noqa: F401 (re-exported by millstab.api)
from millstab.config import Config
from millstab.points import PointSet
from millstab.warnlog import warn

#: candidate speeds of a plan when neither the caller nor the config gives a range: this many evenly
#: spaced speeds over the config's [speeds] range is the finest the plan needs (the lobes of a 5 kHz
#: mode at 20 000 rpm are hundreds of rpm wide)
N_CANDIDATES = 800


def identify(cfg: Config, points: PointSet, *, method: str = "lsq", free: Sequence[str] | str | None = None,
             axisymmetric: bool = False, initial: Mapping[str, float] | str | None = None, engine: str = "zoa",
             seed: int = 0, loss: str = "linear", noise: float | None = None, progress: Progress | None = None):
    """The modal parameters whose SLD explains the boundary points (:func:`millstab.identify.identify`).

    A measured-FRF config starts from its fitted modes (the note is the fit's first warning).

    Raises:
        InputError: unknown method or loss, a robust loss with newton, too few points, bad names.
        Cancelled: raised by ``progress``.
    """
    from millstab.identify import METHODS
    from millstab.identify import identify as run_identify
    from millstab.identify.lsq import LOSSES
    from millstab.identify.quality import check_noise

    if method not in METHODS:
        raise InputError("--method", method, f"must be one of {', '.join(METHODS)}")
    if loss not in LOSSES:
        raise InputError("--loss", loss, f"must be one of {', '.join(LOSSES)}")
    if loss != "linear" and method != "lsq":
        raise InputError("--loss", loss, "a robust loss applies to --method lsq only")
    cfg, _ = modal(cfg)
    points = point_set(points, "points")  # a PointSet, a file, or a notebook's table
    options = {"loss": loss} if method == "lsq" else {}
    options["noise"] = check_noise(noise, "--noise")
    fit = run_identify(cfg, points, method=method, free=free, axisymmetric=axisymmetric, initial=initial,
                       engine=engine, seed=seed, progress=solver_progress(progress, f"identify ({method})"), **options)
    # what it was made from travels in the fit, so every door writes the same JSON (the CLI added these keys)
    made_from = {"config": cfg.name, **({"points": str(points.source)} if points.source is not None else {})}
    return dataclasses.replace(fit, provenance=made_from)


def fit_rpm(points: PointSet, n: int = 600) -> np.ndarray:
    """Speeds that span the points with a 5 % margin [rev/min] (the fitted SLD's figure)."""
    lo, hi = float(points.rpm.min()), float(points.rpm.max())
    pad = 0.05 * (hi - lo) if hi > lo else 0.05 * hi
    return np.linspace(max(lo - pad, 1.0), hi + pad, n)


def fit_curves(fit, cfg: Config, rpm: np.ndarray, engine: str = "zoa") -> np.ndarray:
    """The SLDs of the fit's start (row 0) and estimate (row 1) at ``rpm`` [mm], (2, S)."""
    from millstab.forward import forward

    return forward(fit.par, cfg.cutting, engine)(np.vstack([fit.start, fit.estimate]), rpm) * 1e3


def fit_figure(fit, cfg: Config, points: PointSet, engine: str = "zoa", method: str = "lsq"):
    """The identified SLD over the points, with the start dotted (``millstab identify --plot``)."""
    from millstab.plot.identify import plot_final

    rpm = fit_rpm(points)
    curves = fit_curves(fit, cfg, rpm, engine)
    fig = plot_final([(f"{cfg.name}: identified ({method})", rpm, None, curves[1], points)])
    fig.axes[0].plot(rpm, curves[0], color="0.5", lw=1.0, ls=":", label="start")
    fig.axes[0].legend(fontsize=7)
    return fig


def history_figure(fit):
    """The objective against iteration (``millstab identify --history-plot``)."""
    return fit.figure()


def design(cfg: Config, *, n: int = 20, points: PointSet | None = None, fit=None, fit_source: str = "fit",
           rpm: np.ndarray | None = None, target: Sequence[str] | str | None = None,
           free: Sequence[str] | str | None = None, axisymmetric: bool = False, noise: float = 0.02,
           speed_noise: float = 0.005, samples: int = 16, seed: int = 0, engine: str | None = None):
    """Plan ``n`` boundary-point tests (:func:`millstab.identify.design.design_speeds`).

    Args:
        cfg: the config (cutting conditions, starting structure, [speeds] range).
        points: boundary points already measured (their speeds are part of the plan's information).
        fit: a fit to plan around (a :class:`~millstab.identify.result.Fit` or its JSON document from
            ``millstab identify --out``), named
            ``fit_source`` in messages; without it the plan averages over the prior spread around ``cfg``'s
            structure with the ``free`` parameters (default all), x and y tied with ``axisymmetric``.
        rpm: candidate speeds; default :data:`N_CANDIDATES` over the config's [speeds] range.
        target: the parameters to pin (default every free one).
        engine: the stability engine of the plan's sensitivities and predicted depths; ``None``: the fit's own
            (a fit made with the spectral engine at low immersion was planned with the zero-order one, whose
            depths there were up to 2.8× too deep), else the cheapest.
    Returns:
        :class:`millstab.identify.design.SpeedDesign`.
    """
    from millstab.identify.design import design_speeds
    from millstab.params import Parameterization

    cfg, _ = modal(cfg)
    points = None if points is None else point_set(points, "points")  # a PointSet, a file, or a notebook's table
    if rpm is not None:
        from millstab.stability import check_rpm

        candidates = check_rpm(rpm)
    elif cfg.rpm is not None:
        candidates = np.linspace(float(np.min(cfg.rpm)), float(np.max(cfg.rpm)), N_CANDIDATES)
    else:
        raise InputError("--rpm", None, "the config has no [speeds] range: give candidate speeds as START:STOP:STEP")
    existing = None if points is None else points.subset(points.boundary)
    if isinstance(target, str):
        target = [t.strip() for t in target.split(",") if t.strip()]
    engine = plan_engine(engine, None if fit is None else _fit(fit, fit_source))
    options = dict(n=n, engine=engine, existing_rpm=None if existing is None else existing.rpm,
                   existing_weight=None if existing is None else existing.weight, target=target or None,
                   noise=noise, speed_noise=speed_noise, samples=samples, seed=seed)
    if fit is not None:
        check_fit_matches(fit, fit_source, cfg)
        par, theta, cov, alts = _fit_view(_fit(fit, fit_source), cfg.cutting)
        return design_speeds(par, cfg.cutting, candidates, theta=theta, cov_u=cov, alternatives=alts, **options)
    names = tuple(s.strip() for s in free.split(",") if s.strip()) if isinstance(free, str) else tuple(free or ())
    return design_speeds(Parameterization(cfg.structure, names, axisymmetric), cfg.cutting, candidates, **options)


def plan_engine(engine: str | None, fit=None) -> str:
    """The engine a plan uses: ``engine`` when given (checked), else the fit's (:class:`~millstab.identify.result.Fit`
    settings), else the cheapest."""
    from millstab.stability import check_engine_name, engine_with

    if engine is None:
        engine = (fit.settings.get("engine") if fit is not None else None) or engine_with(cheap=True).name
    return check_engine_name(engine)


def design_figure(plan, cfg: Config, points: PointSet | None = None, fit=None, fit_source: str = "fit"):
    """The plan on the SLD at its centre, with the measured points (``millstab design --plot``); ``fit``: the
    fit JSON the plan was made around, if any (its structure holds the fixed parameters)."""
    from millstab.params import Parameterization
    from millstab.plot.identify import plot_design
    from millstab.stability import get_engine

    eng = get_engine(plan.engine)  # the SLD the plan was made on
    cfg, _ = modal(cfg)
    if fit is not None:
        par = _fit_view(_fit(fit, fit_source), cfg.cutting)[0]
    else:
        par = Parameterization(cfg.structure, plan.names, all("_" not in k for k in plan.names))
    grid = np.linspace(plan.candidates[0], plan.candidates[-1], 800)
    sld = eng.envelope(par.structure(plan.theta), cfg.cutting, grid).depth_mm
    existing = None if points is None else points.subset(points.boundary)
    return plot_design(plan, grid, sld, existing, title=f"{cfg.name}: planned tests")


def check_fit_matches(doc, source: str, cfg: Config) -> None:
    """Refuse a fit JSON made from other cutting conditions or another mode layout than ``cfg``'s; warn
    when the file is too old to record its cutting conditions. ``doc``: the fit JSON, or a Fit."""
    if hasattr(doc, "to_json"):
        doc = doc.to_json()
    rec = doc.get("cutting") if isinstance(doc, dict) else None
    if rec is None:
        warn(f"--fit {source}: the file does not record the cutting conditions it was fitted under (written "
             "by an older millstab), so it cannot be checked against this config: make sure it comes from "
             f"{cfg.name}", UserWarning, stacklevel=2)
    else:
        from millstab.identify.result import cutting_difference

        diff = cutting_difference(rec, cfg.cutting)
        if diff:
            raise InputError("--fit", str(source), f"was fitted under other cutting conditions than {cfg.name}: {diff} "
                                                   "(the config); plan with the config the fit was made from")
    layout = {d: len((doc.get("structure") or {}).get(d) or []) for d in ("x", "y")} if isinstance(doc, dict) else {}
    want_layout = {d: len(getattr(cfg.structure, d)) for d in ("x", "y")}
    if layout and layout != want_layout:
        raise InputError("--fit", str(source),
                         f"its structure has {layout['x']} x and {layout['y']} y mode(s), the config {cfg.name} "
                         f"{want_layout['x']} and {want_layout['y']}: plan with the config the fit was made from")
    made_from = doc.get("config") if isinstance(doc, dict) else None
    if isinstance(made_from, str) and made_from != cfg.name:
        warn(f"--fit {source} was made from config {made_from!r}, this is {cfg.name!r}; their cutting conditions "
             "and modes agree, so the plan goes ahead", UserWarning, stacklevel=2)


def _fit(fit, source: str):
    """A :class:`~millstab.identify.result.Fit` from itself or its JSON document."""
    from millstab.identify.result import Fit

    return fit if isinstance(fit, Fit) else Fit.from_json(fit, str(source))


def _fit_view(fit, cutting):
    """(parameterization, θ, covariance of ln θ or None, alternatives) to plan around a fit: the default
    search bounds around its estimate (as the command has always planned), tied where the fit chose x = y."""
    from millstab.identify.design import fit_view
    from millstab.params import Parameterization

    par0 = Parameterization(fit.structure, fit.names, fit.par.axisymmetric)
    alts = [[a["estimate"][k] for k in fit.names] for a in fit.alternatives]
    return fit_view(par0, cutting, fit.estimate, fit.std_errors, fit.correlation, alts, fit.tied)
