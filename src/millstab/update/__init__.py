"""Bayesian updating of the modal parameters from labelled test cuts, and decisions from the posterior.

* :mod:`~millstab.update.prior` -- heavy-tailed prior around the hammer-test structure (``[prior]``) and
  the priors of the learned noise levels (label error, depth noise);
* :mod:`~millstab.update.conflict` -- does the posterior contradict the hammer test? (a one-line warning);
* :mod:`~millstab.update.predict` -- P(stable) and P(the operator writes chatter) of given cuts;
* :mod:`~millstab.update.likelihood` -- probit likelihood of stable/chatter/marginal labels, chatter
  frequencies and boundary points through the one batched forward function;
* :mod:`~millstab.update.sampler` -- adaptive tempered sequential Monte Carlo;
* :mod:`~millstab.update.posterior` -- the result (samples, summaries, x↔y exchange modes, JSON);
* :mod:`~millstab.update.decide` -- P(stable) maps, the recommended cut and the next test;
* :mod:`~millstab.update.campaign` -- virtual test campaigns (recommend → cut → update) and calibration.

:func:`update` runs the whole chain from a config and a cuts file.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from millstab.points import PointSet
from millstab.update.decide import Recommendation, p_stable_map, recommend
from millstab.update.likelihood import Evidence, Likelihood
from millstab.update.conflict import check as check_conflict, label_error_too_high, label_message
from millstab.update.posterior import Posterior, split_modes
from millstab.update.prior import Prior, make_prior
from millstab.update.sampler import corrected_smc, tempered_smc
from millstab.warnlog import collect, emit, warn

#: the default number of posterior samples (the reference's ~4 000 weighted samples)
DEFAULT_SAMPLES = 4000
#: the MH moves of the sampler: ``plain`` (every proposal through the engine), ``delayed`` (delayed
#: acceptance: proposals screened by the zero-order engine, the accurate engine only on the survivors;
#: the posterior is still the chosen engine's, :mod:`millstab.update.sampler`), ``auto`` (delayed for
#: every engine but ``zoa``, which is its own screen), ``surrogate`` (tempered SMC on the zero-order limits
#: times a correction fitted on a design of accurate evaluations, then the accurate engine once per final
#: particle and an importance correction to its posterior: :func:`millstab.update.sampler.corrected_smc`,
#: :mod:`millstab.update.surrogate`)
SAMPLERS = ("auto", "delayed", "plain", "surrogate")
#: accurate evaluations (distinct zero-order posterior particles) that the ``surrogate`` sampler fits its correction on
SURROGATE_DESIGN = 200
#: the regression of the ``surrogate`` sampler's correction (:data:`millstab.update.surrogate.KINDS`)
SURROGATE_KIND = "linear"
#: the engine that screens proposals in delayed acceptance
SCREEN_ENGINE = "zoa"
#: a fresh delayed-acceptance update's first reweightings by the screen alone (:func:`tempered_smc`'s
#: ``screen_stages``; the accurate engine first sees the distinct particles after them, corrected by a bridge), at
#: most up to the exponent SCREEN_TOP (``screen_top``). Measured (docs/updating-measured.md, "A screen-tempered
#: start"): on the a/D 0.1 spectral case 1.4x fewer accurate sets than 0 stages over 8 seeds, the means as close to a
#: 3 000-sample reference; tempered to 1 (the screen's whole posterior) the bridge's weights collapse, hence the cap
SCREEN_STAGES = 3
SCREEN_TOP = 0.75
#: a fresh delayed-acceptance update's MH moves per stage and the random walk's acceptance target
#: (:func:`tempered_smc`'s ``moves`` and ``accept_target``; plain updates: 3 and
#: :data:`millstab.update.sampler.ACCEPT_TARGET` 0.25). A rejected large step mostly costs only the cheap screen, so
#: longer steps and one more move carry the particles further per accurate evaluation. Measured with SCREEN_TOP 0.75
#: (docs/updating-measured.md, "Longer steps, a later hand-over"): on the a/D 0.1 spectral case over 8 seeds, 1 000
#: samples, 29 % fewer spectral evaluations and 1.41x less CPU than 0.25, 3 moves and SCREEN_TOP 0.5, the means and
#: quantiles as close to a 3 000-sample reference. Its cost: fewer distinct final samples (a proxy calibration, zoa
#: screening zoa, 2 x 100 campaigns: median 378 and 396 against 498 and 485; 3 false conflicts named against 1)
DELAYED_MOVES = 4
DELAYED_ACCEPT_TARGET = 0.15
#: MH steps on the screen per delayed-acceptance proposal (:func:`tempered_smc`'s ``screen_steps``; 1: delayed
#: acceptance)
SCREEN_STEPS = 1
#: delayed acceptance's screen anchored at each particle (:func:`tempered_smc`'s ``anchored``: the zero-order limits of
#: the proposal times the particle's own accurate / zero-order ratio per data column, a state-dependent screen), in a
#: fresh update without measured chatter frequencies (docs/updating-measured.md, "An anchored screen")
ANCHORED = True


def screen_engine(engine: str, sampler: str = "auto") -> str | None:
    """The engine screening the MH proposals for ``engine`` under ``sampler`` (``None``: plain moves).

    Raises:
        InputError: an unknown sampler.
    """
    from millstab.errors import InputError

    if sampler not in SAMPLERS:
        raise InputError("sampler", sampler, "one of " + ", ".join(SAMPLERS))
    if sampler == "plain" or (sampler == "auto" and engine == SCREEN_ENGINE):
        return None
    return SCREEN_ENGINE


def screen_model(prior: Prior, evidence: Evidence, screen: str) -> tuple[Prior, Evidence]:
    """The prior and data the ``screen`` engine reads: the update's own, or, where the cuts carry process damping
    and the screen does not model it (zoa), the same without it. Why: the screen only proposes (delayed acceptance
    is exact for the accurate engine's posterior whatever the screen; the anchored screen's ratio carries the term
    at each particle), and refusing the term there made every update of a process-damping config fail with the
    one engine that models it (sdm) before it started."""
    from dataclasses import replace

    from millstab.stability import get_engine

    cuts = (prior.cutting, *(evidence.conditions or ()))
    if getattr(get_engine(screen), "process_damping", False) or not any(c.has_process_damping for c in cuts):
        return prior, evidence
    plain = replace(prior, cutting=prior.cutting.without_process_damping())
    if not evidence.conditions:
        return plain, evidence
    return plain, replace(evidence, conditions=tuple(c.without_process_damping() for c in evidence.conditions))


def lobe_jump_groups(prior: Prior) -> tuple[tuple[int, ...], ...]:
    """The sampler's lobe-jump groups (:func:`tempered_smc` ``jumps``): each free natural frequency's column
    of u = ln θ alone, and all of them together (a wrong tap test usually shifts every mode alike)."""
    fn = [i for i, name in enumerate(prior.names[:prior.n_modal]) if prior.par.kind(name) == "fn"]
    if not fn:
        return ()
    return tuple((i,) for i in fn) + ((tuple(fn),) if len(fn) > 1 else ())



def warn_speeds_in_hz(config, *point_sets: PointSet | None, stacklevel: int = 3) -> str | None:
    """Warn when every speed of the cuts (and points) lies below a tenth of the config's ``[speeds]`` while 60 times
    the fastest lies within them: the column ``rpm`` then most likely holds rev/s (Hz, a spindle's display or a
    controller's log), and every cut would be fitted 60 times too slow without a word (the update runs: the
    label-error warning it gives blames labels or units vaguely). Returns the message, or ``None``; issued by
    :func:`update` and :func:`millstab.update.validate.cross_validate`."""
    speeds = getattr(config, "rpm", None)
    rpm = np.concatenate([np.asarray(p.rpm, float) for p in point_sets if p is not None and len(p)] or [np.zeros(0)])
    if speeds is None or not len(speeds) or not rpm.size:
        return None
    lo, hi, fastest = float(np.min(speeds)), float(np.max(speeds)), float(rpm.max())
    if not (fastest < lo / 10 and lo / 2 <= 60 * fastest <= 2 * hi):
        return None
    msg = (f"rpm: the fastest cut is {fastest:g} rpm, below a tenth of the config's speeds ({lo:g}-{hi:g} rpm): are "
           f"the speeds in Hz (rev/s)? {fastest:g} rev/s is {60 * fastest:g} rpm; the column rpm is in rev/min")
    warn(msg, UserWarning, stacklevel=stacklevel)
    return msg


def warn_time_averaged_cuts(engine: str, conditions) -> list[str]:
    """Warn when a time-averaged engine fits cuts made with less than one tooth in the cut on average
    (:func:`millstab.stability.time_averaged_note`): the posterior's parameters absorb that model error. Returns the
    messages, which the posterior keeps (its file and every decision from it carry them; each decision warns for
    its own condition besides). Issued by :func:`update` and, once for all its folds, by
    :func:`millstab.update.validate.cross_validate` (whose folds' updates are quiet)."""
    from millstab.points import condition_text
    from millstab.stability import time_averaged_note

    said = []
    for c in conditions:
        note = time_averaged_note(engine, c, f"the cuts made in {condition_text(c)}")
        if note:
            said.append(f"{note}: the posterior's parameters absorb that error, and its decisions inherit it; update "
                        "with --engine spectral or sdm for those cuts")
            warn(said[-1], UserWarning, stacklevel=3)
    return said


def update(config, cuts: PointSet, points: PointSet | None = None, *, engine: str = "zoa",
           samples: int = DEFAULT_SAMPLES, seed: int = 0, moves: int | None = None, prior: Prior | None = None,
           progress: Callable[[str, int, int], None] | None = None, start: Posterior | None = None,
           client=None, sampler: str = "auto", stickout: np.ndarray | None = None,
           engine_options: dict | None = None) -> Posterior:
    """The posterior of the free parameters given labelled cuts (and optional boundary points).

    Args:
        config: a :class:`millstab.config.Config` (structure = prior medians; ``[prior]`` table).
        cuts: labelled cuts (unlabelled rows count as boundary points).
        points: more boundary points (or cuts), or ``None``.
        engine: a registered engine (:data:`millstab.stability.ENGINES`): ``zoa`` (fast) or an
            interrupted-cutting engine (``sdm``, ``spectral``); measured chatter frequencies are used with
            an engine declaring ``reports_chatter_frequency`` (``zoa``, ``spectral``).
        samples: posterior samples (SMC particles).
        seed: seed of the sampler (same seed, same samples).
        moves: Metropolis–Hastings moves per tempering stage; ``None``: :data:`DELAYED_MOVES` in a fresh
            delayed-acceptance update (which also adapts its steps to :data:`DELAYED_ACCEPT_TARGET`), else 3.
        prior: a prior to use instead of the config's.
        start: the posterior of the first cuts of ``cuts`` (sequential reuse: the posterior after n cuts
            is the prior of cut n + 1): its samples start the sampler and only the later cuts are
            tempered in, which takes far fewer stages than a fresh update. Its prior, engine and data must
            be those of this update's first cuts (boundary points included).
        client: a ``distributed.Client``: the likelihood's engine calls run on its cluster where that pays
            (:func:`millstab.cluster.sample_limits`); the same seed gives the same posterior.
        sampler: ``auto``, ``delayed``, ``plain`` or ``surrogate`` (:data:`SAMPLERS`): with ``delayed`` (the
            default for every engine but ``zoa``) the zero-order engine screens each MH proposal and the chosen
            engine decides only on the survivors (delayed acceptance, the screen anchored at each particle by its
            own accurate / zero-order limit ratio where :data:`ANCHORED`; a fresh update's first stages temper the
            zero-order likelihood alone, up to :data:`SCREEN_TOP`, and a bridge hands over); with ``surrogate`` the
            sampler runs on the zero-order limits times a correction fitted on :data:`SURROGATE_DESIGN` accurate
            evaluations, and the chosen engine evaluates the final particles once and corrects the answer by
            importance weights (a fresh update without test-day effect or stickouts only); the posterior is the
            chosen engine's either way.
        stickout: the tool's stickout [m] of each row of ``cuts`` (NaN: the config's); needs a ``[tool]`` +
            ``[holder]`` config whose holder is given by modes, whose prior is then over the holder
            (:mod:`millstab.update.stickout`: one posterior serves every stickout).
        engine_options: the chosen engine's discretisation for the whole update, instead of the one it
            chooses (keywords of its ``envelope_batch``: sdm ``{"steps": 40}`` steps per tooth period,
            spectral ``{"nodes": 8}``; zoa has none): :func:`millstab.forward.engine_options`. The screen
            of delayed acceptance keeps its own. Kept in the posterior (:attr:`Posterior.engine_options`,
            its JSON's ``engine_options``): every decision from it uses them.
    Raises:
        InputError: bad data (see :class:`Evidence`), bad prior, unknown engine, or data no prior
            draw can explain.
    """
    from millstab.update.stickout import config_prior

    pr = prior or config_prior(config)
    cheap_engine = screen_engine(engine, sampler)
    with collect() as caught:
        warn_speeds_in_hz(config, cuts, points)  # kept with the posterior's warnings
        ev = Evidence.from_points(cuts, points, stickout, base_cutting=pr.cutting,
                                  diameter_mm=getattr(config, "diameter_mm", None))
        lik = Likelihood(pr, ev, engine, client, engine_options)
        scr = None if cheap_engine is None else Likelihood(*screen_model(pr, ev, cheap_engine), cheap_engine, client)
    for w in caught:  # pass them on to the caller, and keep them in the result
        emit(w)
    model_error = warn_time_averaged_cuts(engine, ev.conditions or (pr.cutting,))
    # the sampler's vector: ln θ of the free parameters, then the learned noise levels' coordinates, then
    # the test days' shifts of ln fn (millstab.update.batch; none unless [prior] batch_effect)
    be, q = lik.batch, pr.dim
    jumps = lobe_jump_groups(pr)  # the likelihood is multimodal in fn (lobe shifts): sampler.py, "Lobe jumps"
    sample_full, logpdf_full = pr.sample_full, pr.logpdf_full
    if be is not None:
        def sample_full(n, rng):
            return np.hstack([pr.sample_full(n, rng), be.sample(n, rng)])

        def logpdf_full(v):
            return pr.logpdf_full(v[:, :q]) + be.logpdf(v[:, q:])
    # a fresh delayed-acceptance update takes longer steps and one more move (DELAYED_MOVES: measured there only)
    delayed = scr is not None and start is None and sampler != "surrogate"
    if moves is None:
        moves = DELAYED_MOVES if delayed else 3
    sur = None
    if sampler == "surrogate":
        from millstab.errors import InputError
        from millstab.update.surrogate import Corrected

        if start is not None:
            raise InputError("sampler", "surrogate with a start posterior", "sequential reuse: use the delayed sampler")
        rng = np.random.default_rng(seed)
        sur = Corrected(lik, scr)
        # the design: distinct particles of the zero-order posterior (a pilot run as cheap as a zero-order update),
        # where the accurate posterior lies nearby; prior draws spread the fit over a range where the correction
        # is not smooth at low immersion (measured: held-out error 0.23 in ln b against its own sd 0.29)
        pilot = tempered_smc(sample_full, logpdf_full, scr, samples, seed=rng, moves=moves)
        sur.fit(sur.design_from(pilot.u, SURROGATE_DESIGN, rng), SURROGATE_KIND, seed)
        res = corrected_smc(sample_full, logpdf_full, lik, sur, samples, seed=rng, moves=moves, progress=progress)
    elif start is None:
        res = tempered_smc(sample_full, logpdf_full, lik, samples, seed=seed, moves=moves, progress=progress,
                           screen=scr, jumps=jumps, screen_stages=SCREEN_STAGES if delayed else 0,
                           screen_steps=SCREEN_STEPS, screen_top=SCREEN_TOP,
                           anchored=(ANCHORED and delayed and SCREEN_STEPS == 1
                                     and lik.uses_frequency == getattr(scr, "uses_frequency", False)),
                           accept_target=DELAYED_ACCEPT_TARGET if delayed else None)
    else:
        n_old = _check_start(start, pr, ev, engine, dict(lik.options))
        rng = np.random.default_rng(seed)
        u0 = start.sampler_state(rng)
        if be is not None:  # the days the earlier posterior knew keep their shifts; new days start from the prior
            u0 = np.hstack([u0, be.start(start.batch, u0.shape[0], rng)])
        u0 = u0[rng.choice(u0.shape[0], samples, replace=samples > u0.shape[0])] if u0.shape[0] != samples else u0
        res = tempered_smc(sample_full, logpdf_full, lik.split(n_old), samples, seed=rng,
                           moves=moves, progress=progress, init=u0,
                           screen=scr.split(n_old) if scr is not None else None, jumps=jumps)
    diag = res.diagnostics()
    # how many of the cuts came from the earlier posterior (--start): only the others were tempered in
    diag["started_from_cuts"] = 0 if start is None else n_old
    diag["engine_sets"] = lik.n_sets
    # (set, speed) limits the engine stopped above their ceiling (Likelihood.ceilings: log L unchanged)
    diag["censored_entries"] = lik.n_censored
    # (set, speed) limits below their floor (Likelihood.floors: log L the same bits), floored or searched
    diag["floored_entries"] = lik.n_floored
    if engine_options:
        diag["engine_options"] = dict(engine_options)
    if scr is not None:
        diag["screen_engine"], diag["screen_sets"] = cheap_engine, scr.n_sets
        # the bounded second stage (Likelihood.bounded): proposals rejected before all their speeds were evaluated,
        # and the (set, speed) evaluations that saved
        diag["decided_early"], diag["entries_saved"] = lik.n_decided, lik.n_entries_saved
    if sur is not None:
        diag["surrogate"] = sur.report()
    diag["frequency_term"] = lik.uses_frequency
    data = {"rpm": np.r_[ev.cut_rpm, ev.pt_rpm].tolist(), "depth_mm": np.r_[ev.cut_depth_mm, ev.pt_depth_mm].tolist(),
            "label": [("stable", "chatter", "marginal")[k] for k in ev.cut_kind] + [""] * ev.pt_rpm.size,
            "chatter_hz": [None if not np.isfinite(h) else float(h) for h in ev.cut_hz] + [None] * ev.pt_rpm.size,
            "grade": [float(g) for g in ev.cut_grade] + [None] * ev.pt_rpm.size}
    if stickout is not None:  # each row's stickout [mm] (None: the config's)
        so = np.r_[ev.cut_stickout, ev.pt_stickout] * 1e3
        data["stickout_mm"] = [None if np.isnan(v) else float(v) for v in so]
    if be is not None:
        data["batch"] = [str(b) for b in ev.cut_batch] + [""] * ev.pt_rpm.size
    conditions = ev.conditions or ()
    if ev.conditions is not None:  # the trained conditions: each row's index (docs/updating.md, "Many conditions")
        data["condition"] = np.r_[ev.cut_cond, ev.pt_cond].astype(int).tolist()
    u = res.u[:, :pr.size]
    noise = None
    days = None if be is None else be.posterior(res.u[:, q:])
    if pr.dim > pr.size:
        eps, fac = pr.noise(res.u[:, pr.size:q], samples)
        noise = np.stack([eps if n == "label_error" else fac for n in pr.noise_names], axis=1)
    dia = getattr(config, "diameter_mm", None)
    opts = dict(lik.options)  # checked against the engine (millstab.forward.engine_options)
    post = Posterior(pr, np.exp(u), engine, diag, data, (), noise, days, conditions=conditions, diameter_mm=dia,
                     engine_options=opts)
    messages = [str(w.message) for w in caught] + model_error
    modes = post.modes()
    twin = split_modes(pr, post.samples, engine) if len(modes) > 1 else None
    main = u if twin is None else u[twin if twin.mean() > 0.5 else ~twin]  # the larger mode's samples
    # hysteresis: a conflict the update this one continues named by its evidence ratio is kept while the
    # ratio stays ≥ conflict.BAYES_FACTOR_KEEP (docs/updating.md, "Prior–data conflict")
    before = start is not None and bool((start.diagnostics.get("conflict") or {}).get("conflict"))
    msg, diag["conflict"] = check_conflict(pr, main, named_before=before)
    if msg is None and noise is not None and label_error_too_high(pr, post.label_error) and ev.n_cuts:
        from millstab.update.predict import predict_cuts  # one more engine call, only in this case

        ps, _ = predict_cuts(post, ev.cut_rpm, ev.cut_depth_mm, ev.conditions, ev.cut_cond, batch=ev.cut_batch)
        msg = label_message(pr, post.label_error, ev.cut_rpm, ev.cut_depth_mm, ev.cut_grade, ps)
        diag["conflict"]["labels"] = True
    if msg is not None:  # issued (the doors print it in one line) and kept in the result
        warn(msg, UserWarning, stacklevel=2)
        messages.append(msg)
    # the bimodal warning (not issued, as before: a property of the answer) joins them in Posterior itself
    return Posterior(pr, post.samples, engine, diag, data, tuple(messages), noise, days, conditions=conditions,
                     diameter_mm=dia, engine_options=opts)


def _check_start(start: Posterior, prior: Prior, ev: Evidence, engine: str, options: dict | None = None) -> int:
    """The number of earlier cuts of ``start`` after checking that it is this update's own beginning (its prior,
    engine, engine options and data)."""
    from millstab.errors import InputError

    same_prior = (start.prior.names == prior.names and np.allclose(start.prior.median, prior.median, rtol=1e-12)
                  and np.allclose(start.prior.spread, prior.spread, rtol=1e-12)
                  and start.prior.sigma_depth_m == prior.sigma_depth_m
                  and start.prior.sigma_depth_rel == prior.sigma_depth_rel
                  and start.prior.label_error == prior.label_error and start.prior.tails == prior.tails
                  and start.prior.noise_names == prior.noise_names and start.prior.batch_effect == prior.batch_effect)
    if not same_prior or start.engine != engine:
        raise InputError("start", "a posterior of another prior or engine",
                         "start from a posterior of the same config, [prior] table and engine")
    if dict(start.engine_options) != dict(options or {}):  # its samples follow another discretisation's likelihood
        raise InputError("start", f"a posterior fitted with engine options {start.engine_options or 'none'}",
                         f"start from one fitted with this update's ({options or 'none'})")
    c = start.cuts or {}
    lab = list(c.get("label") or [])
    n_old = sum(1 for x in lab if x)
    n_pts = len(lab) - n_old
    kinds = [("stable", "chatter", "marginal")[k] for k in ev.cut_kind[:n_old]]
    ok = (n_old <= ev.n_cuts and n_pts == ev.pt_rpm.size and kinds == lab[:n_old]
          and np.allclose(np.asarray(c.get("rpm", [])[:n_old], float), ev.cut_rpm[:n_old])
          and np.allclose(np.asarray(c.get("depth_mm", [])[:n_old], float), ev.cut_depth_mm[:n_old])
          and np.allclose(np.asarray(c.get("rpm", [])[n_old:], float), ev.pt_rpm)
          and (prior.batch_effect == 0 or list(c.get("batch", [])[:n_old]) == [str(b) for b in ev.cut_batch[:n_old]])
          and _same_conditions(start, ev, n_old))
    if not ok:
        raise InputError("start", f"a posterior of {n_old} cuts and {n_pts} points",
                         "its cuts must be the first cuts of this update (same order, labels, boundary points)")
    return n_old


def _same_conditions(start: Posterior, ev: Evidence, n_old: int) -> bool:
    """True when the earlier cuts (and the boundary points) were in the same cutting conditions as now."""
    from millstab.points import same_condition

    def conds(trained, index, n):
        index = list(index) if index is not None else [0] * n
        return [trained[int(i)] for i in index]

    c = start.cuts or {}
    old = conds(start.trained_conditions, c.get("condition"), len(c.get("label") or []))
    now_all = ev.conditions or (start.prior.cutting,)
    now = conds(now_all, np.r_[ev.cut_cond[:n_old], ev.pt_cond], n_old + ev.pt_rpm.size)
    return len(old) == len(now) and all(same_condition(a, b) for a, b in zip(old, now))


__all__ = ["DEFAULT_SAMPLES", "SAMPLERS", "screen_engine", "screen_model", "Evidence", "Likelihood", "Posterior",
           "Prior", "Recommendation", "make_prior", "p_stable_map", "recommend", "update", "warn_speeds_in_hz",
           "warn_time_averaged_cuts"]
