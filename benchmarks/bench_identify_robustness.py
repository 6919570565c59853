"""Held-out robustness of the default solver (lsq) on random identification cases.

Cases (millstab.identify.synthetic.random_case, seeded): fn_x 300–5000 Hz, fn_y within ×/÷ 1.5 of fn_x,
k 2–50 N/µm, ζ 0.005–0.08, 2–6 teeth, radial immersion 5–100 %, up or down milling; 100 speeds over
tooth-passing 0.1–0.6 of the lower natural frequency; start: every parameter uniformly within ±30 %.
A draw is kept only if the points determine all six parameters — smallest singular value of
J = ∂ln b/∂ln θ (÷√n) at the truth ≥ 0.01 (millstab.identify.synthetic.identifiability); the number
of draws rejected is printed (those are cases no method can solve: a mode that hardly shows).

* noise-free: recovered = every parameter within 0.1 % (up to the exact x↔y exchange where the cut has
  one: the plain swap when α_xx = α_yy, e.g. slotting; otherwise, whenever α_xx α_yy > 0, the exchange
  with k_x' = (α_xx/α_yy) k_y, k_y' = k_x α_yy/α_xx — millstab.identify.objective.exchange_map — which
  leaves the zero-order SLD unchanged exactly, so no method can tell which of the two is the truth);
* 2 % Gaussian relative noise on the depths (seeded): fn within 0.5 %, and the coverage of the
  reported ±2σ intervals (per parameter, over all cases; nominal 95 %), for two ways of choosing the
  100 speeds:

  - **evenly spaced**: the 100 speeds above. How well they pin fn is luck: the weaker mode of a tool
    often gets a standard error of 0.3–1 %, so no estimator can keep it within 0.5 % every time. The
    line also prints how many cases an efficient unbiased estimator would meet on average (from the
    Cramér–Rao bound at the truth), to tell the data's limit from the solver's;
  - **planned** (how an experimenter would spend the same budget): 50 evenly spaced speeds, a first
    fit, then 50 tests planned by ``millstab.identify.design.design_after_fit`` around that fit (its
    covariance and alternatives; candidates: tooth-passing 0.05–1.2 of the fit's higher natural
    frequency), measured with fresh noise, and one fit of all 100 points from the same ±30 % start.
    ``--stages 3``: 33 evenly spaced, then two rounds of fit-and-plan (33 + 34 tests).

Run: ``.venv/bin/python benchmarks/bench_identify_robustness.py [--cases 50] [--seed 0] [--stages 2]``
(about 2 minutes).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.identify import fit_lsq, make_problem  # noqa: E402
from millstab.identify.design import design_after_fit, log_jacobians  # noqa: E402
from millstab.identify.objective import exchange_map, oriented, rel_error, swap_permutation  # noqa: E402
from millstab.identify.synthetic import boundary_points, identifiability, random_case  # noqa: E402
from millstab.io.points import PointSet  # noqa: E402
from millstab.params import Parameterization  # noqa: E402

#: candidate speeds of the planned tests: tooth-passing frequency over this band of the first fit's
#: higher natural frequency
PLAN_BAND = (0.05, 1.2)


class Tally:
    """fn-within-0.5 % count and ±2σ coverage of one speed design's noisy fits."""

    def __init__(self) -> None:
        self.ok_fn = self.covered = self.total = self.all_covered = 0
        self.expected = 0.0

    def add(self, fit, prob, truth, noise: float) -> tuple[float, float, int]:
        """Score a fit (in the x↔y orientation closer to the truth); returns (fn error, fn σ, covered).

        Also adds the probability that an efficient unbiased estimator keeps every fn within 0.5 % with
        these speeds: Π 2Φ(0.5 %/σ_j) − 1, σ_j the Cramér–Rao bound noise·√((JᵀJ)⁻¹)_jj at the truth
        (J = ∂ ln b/∂ ln θ; the fn errors taken as independent)."""
        perm = swap_permutation(prob.par, prob.cutting)
        sym = perm if perm is not None else exchange_map(prob.par, prob.cutting, prob.engine)
        est, se = oriented(fit.estimate, truth, sym, fit.std_errors)
        fn = [j for j, name in enumerate(prob.par.free) if name.startswith("fn")]
        jac = log_jacobians(prob.par, prob.cutting, truth[None], prob.rpm)[0][0]
        crb = noise * np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)))
        self.expected += float(np.prod(2 * stats.norm.cdf(5e-3 / crb[fn]) - 1))
        err = float(np.abs(est / truth - 1)[fn].max())
        cov = np.abs(est - truth) <= 2 * se
        self.ok_fn += err < 5e-3
        self.covered += int(cov.sum())
        self.total += cov.size
        self.all_covered += bool(cov.all())
        return err, float(max(se[j] / truth[j] for j in fn)), int(cov.sum())

    def line(self, n: int) -> str:
        return (f"fn within 0.5 % in {self.ok_fn}/{n} (an efficient estimator: {self.expected:.1f} on average); ±2σ coverage {self.covered}/{self.total} = "
                f"{100 * self.covered / self.total:.1f} % of parameters ({self.all_covered}/{n} sets with all six covered)")


def planned_fit(case, i: int, noise: float, stages: int = 2):
    """The planned protocol (module docstring) in ``stages`` rounds: n/stages evenly spaced speeds, then
    each round a fit of everything so far and an equal share of planned tests; returns (problem, fit)
    of all n points."""
    n = case.rpm.size
    rpm = np.linspace(case.rpm[0], case.rpm[-1], n // stages)
    pts = boundary_points(case.structure, case.cutting, rpm, noise=noise, seed=2000 + i)
    for stage in range(1, stages):
        fit = fit_lsq(make_problem(case.start, case.cutting, pts), seed=i)
        f_hi = max(fit.estimate[fit.names.index("fn_x")], fit.estimate[fit.names.index("fn_y")])
        cand = np.linspace(*PLAN_BAND, 800) * 60 * f_hi / case.cutting.teeth
        todo = (n - pts.rpm.size) // (stages - stage)
        plan = design_after_fit(fit, case.cutting, cand, todo, existing_rpm=pts.rpm, noise=noise, seed=i)
        new = boundary_points(case.structure, case.cutting, plan.rpm, noise=noise, seed=1000 * (2 + stage) + i)
        pts = PointSet(np.concatenate([pts.rpm, new.rpm]), np.concatenate([pts.depth_mm, new.depth_mm]))
    prob = make_problem(case.start, case.cutting, pts)
    return prob, fit_lsq(prob, seed=i)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--stages", type=int, default=2, help="planned protocol: evenly spaced first share, then this many - 1 planned rounds")
    ap.add_argument("--band", type=float, nargs=2, default=(0.1, 0.6), metavar=("LO", "HI"),
                    help="tooth-passing frequency band of the speeds, as fractions of the lower natural frequency")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(args.seed)
    ok_clean = rejected = n_exch = 0
    even, planned = Tally(), Tally()
    times = []
    t_all = time.perf_counter()
    with threadpool_limits(1):
        i = 0
        while i < args.cases:
            case = random_case(rng, band=tuple(args.band))
            if identifiability(case.structure, case.cutting, case.rpm) < 1e-2:
                rejected += 1
                continue
            truth = Parameterization(case.structure).theta0
            # noise-free
            prob = make_problem(case.start, case.cutting, boundary_points(case.structure, case.cutting, case.rpm))
            perm = swap_permutation(prob.par, prob.cutting)
            sym = perm if perm is not None else exchange_map(prob.par, prob.cutting, prob.engine)
            n_exch += sym is not None
            fit = fit_lsq(prob, seed=i)
            times.append(fit.time_s)
            e = rel_error(fit.estimate, truth, sym)
            ok_clean += bool(e.max() < 1e-3)
            # noisy, evenly spaced speeds
            pts = boundary_points(case.structure, case.cutting, case.rpm, noise=args.noise, seed=1000 + i)
            probn = make_problem(case.start, case.cutting, pts)
            err_e, sd_e, cov_e = even.add(fit_lsq(probn, seed=i), probn, truth, args.noise)
            # noisy, half evenly spaced and half planned
            probp, fitp = planned_fit(case, i, args.noise, args.stages)
            err_p, sd_p, cov_p = planned.add(fitp, probp, truth, args.noise)
            flag = "" if e.max() < 1e-3 else "  <- not recovered"
            print(f"case {i:2d}: {case.cutting.teeth} teeth, immersion {np.degrees(case.cutting.entry):5.1f}-"
                  f"{np.degrees(case.cutting.exit):5.1f} deg, fn {truth[0]:6.0f}/{truth[3]:6.0f} Hz: clean max err "
                  f"{100 * e.max():.1e} %{flag}; noisy fn err (σ), ±2σ covers: evenly spaced {100 * err_e:.3f} % "
                  f"({100 * sd_e:.3f} %) {cov_e}/6, planned {100 * err_p:.3f} % ({100 * sd_p:.3f} %) {cov_p}/6", flush=True)
            i += 1
    n = args.cases
    print(f"draws rejected as not identifiable (s_min < 0.01): {rejected}")
    print(f"noise-free: {ok_clean}/{n} recovered within 0.1 % in every parameter "
          f"(up to the exact x↔y exchange, which {n_exch}/{n} cuts have)")
    print(f"{100 * args.noise:g} % noise, 100 evenly spaced speeds: {even.line(n)}")
    print(f"{100 * args.noise:g} % noise, {100 // args.stages} evenly spaced + {100 - 100 // args.stages} planned in "
          f"{args.stages - 1} round(s): {planned.line(n)}")
    print(f"lsq time per noise-free fit: median {np.median(times):.2f} s, max {np.max(times):.2f} s; "
          f"total {time.perf_counter() - t_all:.0f} s")


if __name__ == "__main__":
    main()
