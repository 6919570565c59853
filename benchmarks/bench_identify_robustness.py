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
(about 2 minutes). On a Dask cluster: ``--workers N`` (a local cluster started for the run) or ``--dask
ADDRESS`` (a running scheduler): one task per case (:func:`millstab.cluster.stream`). The cases are drawn
here, in order, from the one seeded stream (the rejected draws included), exactly as the serial run
draws them; every fit is seeded by the case's index, and the totals are summed in case order, so the
figures printed are the serial run's (the case lines come in the order the tasks finish).
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
from millstab.points import PointSet  # noqa: E402
from millstab.params import Parameterization  # noqa: E402

#: candidate speeds of the planned tests: tooth-passing frequency over this band of the first fit's
#: higher natural frequency
PLAN_BAND = (0.05, 1.2)


class Tally:
    """fn-within-0.5 % count and ±2σ coverage of one speed design's noisy fits."""

    def __init__(self) -> None:
        self.ok_fn = self.covered = self.total = self.all_covered = 0
        self.expected = 0.0

    @staticmethod
    def score(fit, prob, truth, noise: float) -> tuple[float, float, int, int, int, float]:
        """Score a fit (in the x↔y orientation closer to the truth); returns (fn error, fn σ, parameters
        covered, parameters, all covered, P(efficient estimator within 0.5 %)).

        Also adds the probability that an efficient unbiased estimator keeps every fn within 0.5 % with
        these speeds: Π 2Φ(0.5 %/σ_j) − 1, σ_j the Cramér–Rao bound noise·√((JᵀJ)⁻¹)_jj at the truth
        (J = ∂ ln b/∂ ln θ; the fn errors taken as independent)."""
        perm = swap_permutation(prob.par, prob.cutting)
        sym = perm if perm is not None else exchange_map(prob.par, prob.cutting, prob.engine)
        est, se = oriented(fit.estimate, truth, sym, fit.std_errors)
        fn = [j for j, name in enumerate(prob.par.free) if name.startswith("fn")]
        jac = log_jacobians(prob.par, prob.cutting, truth[None], prob.rpm)[0][0]
        crb = noise * np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)))
        expected = float(np.prod(2 * stats.norm.cdf(5e-3 / crb[fn]) - 1))
        err = float(np.abs(est / truth - 1)[fn].max())
        cov = np.abs(est - truth) <= 2 * se
        return err, float(max(se[j] / truth[j] for j in fn)), int(cov.sum()), int(cov.size), int(cov.all()), expected

    def add(self, score: tuple) -> None:
        """Count one case's :meth:`score` (call in case order: ``expected`` is a float sum)."""
        err, _, covered, total, all_covered, expected = score
        self.expected += expected
        self.ok_fn += err < 5e-3
        self.covered += covered
        self.total += total
        self.all_covered += all_covered

    def line(self, n: int) -> str:
        return (f"fn within 0.5 % in {self.ok_fn}/{n} (an efficient estimator: {self.expected:.1f} on average); ±2σ "
                f"coverage {self.covered}/{self.total} = {100 * self.covered / self.total:.1f} % of parameters "
                f"({self.all_covered}/{n} sets with all six covered)")


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


def run_case(case, i: int, noise: float, stages: int) -> dict:
    """Case ``i`` alone (a pure function of the case and its index: the same record here or on a worker):
    the noise-free fit, and the scores of the noisy evenly spaced and planned fits."""
    truth = Parameterization(case.structure).theta0
    # noise-free
    prob = make_problem(case.start, case.cutting, boundary_points(case.structure, case.cutting, case.rpm))
    perm = swap_permutation(prob.par, prob.cutting)
    sym = perm if perm is not None else exchange_map(prob.par, prob.cutting, prob.engine)
    fit = fit_lsq(prob, seed=i)
    e = rel_error(fit.estimate, truth, sym)
    # noisy, evenly spaced speeds
    pts = boundary_points(case.structure, case.cutting, case.rpm, noise=noise, seed=1000 + i)
    probn = make_problem(case.start, case.cutting, pts)
    even = Tally.score(fit_lsq(probn, seed=i), probn, truth, noise)
    # noisy, half evenly spaced and half planned
    probp, fitp = planned_fit(case, i, noise, stages)
    planned = Tally.score(fitp, probp, truth, noise)
    flag = "" if e.max() < 1e-3 else "  <- not recovered"
    line = (f"case {i:2d}: {case.cutting.teeth} teeth, immersion {np.degrees(case.cutting.entry):5.1f}-"
            f"{np.degrees(case.cutting.exit):5.1f} deg, fn {truth[0]:6.0f}/{truth[3]:6.0f} Hz: clean max err "
            f"{100 * e.max():.1e} %{flag}; noisy fn err (σ), ±2σ covers: evenly spaced {100 * even[0]:.3f} % "
            f"({100 * even[1]:.3f} %) {even[2]}/6, planned {100 * planned[0]:.3f} % ({100 * planned[1]:.3f} %) "
            f"{planned[2]}/6")
    return {"ok": bool(e.max() < 1e-3), "exchange": sym is not None, "time_s": fit.time_s, "even": even,
            "planned": planned, "line": line}


def _case_task(noise: float, stages: int, case, i: int) -> dict:
    """One case on a cluster worker, numba and BLAS on one thread (the workers are the parallelism)."""
    from millstab.cluster import one_thread

    one_thread()
    with threadpool_limits(1):
        return run_case(case, i, noise, stages)


def draw_cases(rng: np.random.Generator, n: int, band: tuple[float, float]) -> tuple[list, int]:
    """The first ``n`` identifiable cases of the stream (and the number of draws rejected)."""
    cases, rejected = [], 0
    while len(cases) < n:
        case = random_case(rng, band=band)
        if identifiability(case.structure, case.cutting, case.rpm) < 1e-2:
            rejected += 1
            continue
        cases.append(case)
    return cases, rejected


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--stages", type=int, default=2,
                    help="planned protocol: evenly spaced first share, then this many - 1 planned rounds")
    ap.add_argument("--band", type=float, nargs=2, default=(0.1, 0.6), metavar=("LO", "HI"),
                    help="tooth-passing frequency band of the speeds, as fractions of the lower natural frequency")
    ap.add_argument("--workers", type=int, default=None,
                    help="run the cases on a local Dask cluster of N worker processes")
    ap.add_argument("--dask", default=None, metavar="ADDRESS", help="run the cases on the Dask scheduler at ADDRESS")
    args = ap.parse_args()
    print(describe())
    rng = np.random.default_rng(args.seed)
    t_all = time.perf_counter()
    records: list = [None] * args.cases
    with threadpool_limits(1):
        cases, rejected = draw_cases(rng, args.cases, tuple(args.band))
        if args.workers is None and args.dask is None:
            for i, case in enumerate(cases):
                records[i] = run_case(case, i, args.noise, args.stages)
                print(records[i]["line"], flush=True)
        else:
            from millstab.cluster import open_client, stream

            def take(i: int, rec: dict) -> None:
                records[i] = rec
                print(rec["line"], flush=True)

            with open_client(args.dask, args.workers) as client:
                print(f"Dask: {len(client.scheduler_info()['workers'])} workers; one task per case", flush=True)
                stream(client, _case_task, [(case, i) for i, case in enumerate(cases)], take,
                       common=(args.noise, args.stages), name="identify-case")
    even, planned = Tally(), Tally()
    for rec in records:  # in case order: the float sums are those of the serial run
        even.add(rec["even"])
        planned.add(rec["planned"])
    ok_clean = sum(r["ok"] for r in records)
    n_exch = sum(r["exchange"] for r in records)
    times = [r["time_s"] for r in records]
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
