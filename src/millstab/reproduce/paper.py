"""``millstab reproduce``: every table and figure of the seed paper, our values beside the paper's.

Each step computes its numbers in the run (nothing pasted); the paper's numbers come from the one data
file ``datasets/paper_values.toml``, cited to their tables. Steps:

1. Table 1 and the SLDs of the three synthetic examples (ZOA, with SDM as the time-domain check);
2. Table 3: identification of Examples 1–3, the paper's Newton–Raphson scheme and our default solver,
   with Fig. conv, Fig. iter (Example 3) and Fig. eggs;
3. Table 4 and Fig. fourSLD: the four-flute tool's static SLD against the in-process results;
4. the experimental identification on a stand-in point set (the 21 tests are not public);
5. Fig. SENS and Table 6: one-at-a-time and Monte Carlo sensitivity.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from millstab.datasets import load_example, paper_values
from millstab.model import Structure
from millstab.reproduce.report import ReportWriter
from millstab.stability import engine_with

#: the seed paper's method is the zero-order solution: the time-averaged engine (zoa)
zoa = engine_with(time_averaged=True)

PARAM_ROWS = [("fn_x", "Hz", 1.0), ("k_x", "N/µm", 1e-6), ("zeta_x", "-", 1.0),
              ("fn_y", "Hz", 1.0), ("k_y", "N/µm", 1e-6), ("zeta_y", "-", 1.0)]


@dataclass
class Context:
    """What every step needs: the report, the run's options and a progress callback."""

    report: ReportWriter
    quick: bool
    seed: int
    points: Path | None = None
    progress: object = None
    timings: dict[str, float] = field(default_factory=dict)

    @contextmanager
    def step(self, name: str):
        """Time a step (into ``timings``) and report it to the progress display."""
        t = time.perf_counter()
        if self.progress:
            self.progress(name)
        yield
        self.timings[name] = time.perf_counter() - t


def speeds_of(name: str, n: int = 600) -> np.ndarray:
    """An evenly spaced speed grid over the packaged example's [speeds] range [rpm]."""
    cfg = load_example(name)
    return np.linspace(cfg.rpm.min(), cfg.rpm.max(), n)


# --- step 1: Table 1 and the synthetic SLDs ---------------------------------------------------------

#: Table 1's rows: (key in paper_values.toml, label, scale to the table's unit)
TABLE1_ROWS = [("fn_x", "fn_x [Hz]", 1), ("k_x", "k_x [N/µm]", 1e-6), ("zeta_x", "zeta_x", 1),
               ("fn_y", "fn_y [Hz]", 1), ("k_y", "k_y [N/µm]", 1e-6), ("zeta_y", "zeta_y", 1),
               ("kt", "Kt [N/mm²]", 1e-6), ("kr", "kn = Kr", 1), ("entry_deg", "entry [deg]", 1),
               ("exit_deg", "exit [deg]", 1), ("teeth", "teeth", 1)]
#: the synthetic examples of Table 1 and Table 3
EXAMPLES = ("ex1", "ex2", "ex3")
#: SDM (the full run's time-domain check of Table 1's SLDs) on every n-th speed of the ZOA grid
SDM_EVERY = 6


@dataclass(frozen=True)
class ExampleSLD:
    """One synthetic example's SLD for Table 1's figure and summary.

    Attributes:
        name, title: the example ("ex1") and its panel's title (teeth, entry angle).
        rpm: the speeds [rev/min]; depth: the ZOA limit [m]; chatter_hz: its chatter frequency [Hz].
        sdm: (rpm, depth [m]) of SDM on every :data:`SDM_EVERY`-th speed; None in the --quick run.
    """

    name: str
    title: str
    rpm: np.ndarray
    depth: np.ndarray
    chatter_hz: np.ndarray
    sdm: tuple | None


@dataclass(frozen=True)
class Table1:
    """What :func:`compute_table1` computed, from which :func:`render_table1` and :func:`table1_checks` read.

    Attributes:
        inputs: Table 1's rows: label, then (paper, ours) for each of :data:`EXAMPLES`, in the table's unit.
        mismatches: how many of those pairs differ (beyond 1e-9 relative).
        slds: the three examples' SLDs (:class:`ExampleSLD`).
    """

    inputs: tuple
    mismatches: int
    slds: tuple


def compute_table1(quick: bool) -> Table1:
    """Table 1 (the paper's inputs beside the packaged configs) and the SLDs of the three synthetic examples
    (ZOA; SDM as the time-domain check except in the --quick run)."""
    paper = paper_values()["input_values"]
    rows = []
    mismatches = 0
    for key, label, scale in TABLE1_ROWS:
        row = [label]
        for ex in EXAMPLES:
            cfg = load_example(ex)
            ours = _config_value(cfg, key) * scale
            theirs = paper[ex][key] * scale
            mismatches += not math.isclose(ours, theirs, rel_tol=1e-9, abs_tol=1e-12)
            row += [theirs, ours]
        rows.append(tuple(row))
    slds = []
    for ex in EXAMPLES:
        cfg = load_example(ex)
        rpm = speeds_of(ex, 250 if quick else 600)
        env = zoa.envelope(cfg.structure, cfg.cutting, rpm)
        sdm = None
        if not quick:
            engine = engine_with(time_averaged=False, cheap=False)  # semi-discretization, the time-domain reference
            r_sdm = rpm[::SDM_EVERY]
            sdm = (r_sdm, engine.envelope(cfg.structure, cfg.cutting, r_sdm).depth)
        slds.append(ExampleSLD(ex, f"{ex}: {cfg.cutting.teeth} teeth, entry {math.degrees(cfg.cutting.entry):.1f}°",
                               rpm, env.depth, env.chatter_hz, sdm))
    return Table1(tuple(rows), int(mismatches), tuple(slds))


def table1_checks(t: Table1) -> list:
    """The headline row: the packaged configs equal the paper's Table 1."""
    from millstab.reproduce.report import Check

    return [Check("Packaged configs equal the paper's Table 1", f"{t.mismatches} mismatching values",
                  t.mismatches == 0)]


def render_table1(rep: ReportWriter, t: Table1) -> None:
    """The section: Table 1, its check, the SLD figure and summary, all from ``t`` (no engine call)."""
    from millstab.plot.sld import plot_sld_panels

    rep.heading("Table 1: inputs of the synthetic examples")
    rep.paragraph("The paper's Table 1 prints stiffness as 'N/m' and Kt as N/mm²; they are N/µm and MPa. "
                  "'paper' is the value printed in the table, 'ours' the value in millstab's packaged config "
                  "(example:ex1, example:ex2, example:ex3), in the same units.")
    rep.table("table1_inputs", ["parameter", "Ex.1 paper", "Ex.1 ours", "Ex.2 paper", "Ex.2 ours", "Ex.3 paper",
                                "Ex.3 ours"], [list(r) for r in t.inputs], "Table 1: inputs, paper vs packaged configs")
    for c in table1_checks(t):
        rep.add(c)
    panels, rows = [], []
    for e in t.slds:
        depth_mm = e.depth * 1e3
        curves = [("zero-order (ZOA)", e.rpm, depth_mm)]
        sdm_txt = "not run (--quick)"
        if e.sdm is not None:
            r_sdm, d_sdm = e.sdm[0], e.sdm[1] * 1e3
            curves.append(("semi-discretization (SDM)", r_sdm, d_sdm))
            rel = np.abs(d_sdm / depth_mm[::SDM_EVERY] - 1)
            sdm_txt = f"{100 * np.median(rel):.1f} % / {100 * rel.max():.1f} %"
        panels.append((e.title, curves))
        i = int(np.argmin(e.depth))
        rows.append([e.name, e.rpm.min(), e.rpm.max(), depth_mm[i], e.rpm[i], e.chatter_hz[i], sdm_txt])
    fig = plot_sld_panels(panels)
    rep.figure("fig_sld_examples", fig, "SLDs of the three synthetic examples (the targets of Table 3); SDM dashed")
    rep.table("sld_examples_summary", ["example", "from rpm", "to rpm", "min b_lim [mm]", "at rpm", "chatter [Hz]",
                                       "SDM vs ZOA median / max difference"], rows,
              "SLD summary; SDM is the time-domain cross-check (it differs where the directional matrix varies in "
              "time)")


def table1(ctx: Context) -> None:
    """Table 1 (inputs of the synthetic examples) beside the packaged configs, and their SLDs."""
    render_table1(ctx.report, compute_table1(ctx.quick))


def _config_value(cfg, key: str) -> float:
    c, s = cfg.cutting, cfg.structure
    if key in ("kt", "kr", "teeth"):
        return float(getattr(c, key))
    if key == "entry_deg":
        return round(math.degrees(c.entry), 6)
    if key == "exit_deg":
        return round(math.degrees(c.exit), 6)
    p, d = key.split("_")
    return float(getattr(getattr(s, d)[0], p))


# --- step 3: Table 4 and Fig. fourSLD ---------------------------------------------------------------

def in_process_structures() -> dict[str, Structure]:
    """The paper's in-process results for the four-flute tool (axisymmetric, one mode per direction)."""
    er = paper_values()["experimental_results"]
    labels = {"newton_raphson": "Newton–Raphson (paper)", "method1_two_point": "Method 1: two-point (Eynian)",
              "method2_regression": "Method 2: regression (Eynian)"}
    return {labels[k]: Structure.symmetric(v["fn"], v["k"], v["zeta"]) for k, v in er.items() if k in labels}


def table4(ctx: Context, points=None) -> dict:
    """Table 4 (static modal parameters) and Fig. fourSLD; returns the static and in-process SLDs."""
    rep = ctx.report
    pv = paper_values()
    cfg = load_example("fourflute")
    rep.heading("Table 4 and Fig. fourSLD: the four-flute tool")
    modal = pv["modal"]
    rows = []
    for key, label, scale in [("fn_x", "fn_x [Hz]", 1), ("k_x", "k_x [MN/m]", 1e-6), ("zeta_x", "zeta_x", 1),
                              ("fn_y", "fn_y [Hz]", 1), ("k_y", "k_y [MN/m]", 1e-6), ("zeta_y", "zeta_y", 1)]:
        p, d = key.split("_")
        ours = [getattr(m, p) * scale for m in getattr(cfg.structure, d)]
        rows.append([label, modal[key][0] * scale, ours[0], modal[key][1] * scale, ours[1]])
    rep.table("table4_static_modal", ["parameter", "Mode 1 paper", "Mode 1 ours", "Mode 2 paper", "Mode 2 ours"], rows,
              "Table 4: static (hammer-test) modal parameters, two modes per direction; Kt 1110 MPa, Kr 0.22, 4 teeth, "
              "slotting")
    rpm = np.linspace(5000, 7000, 401 if ctx.quick else 801)
    curves = {"static (Table 4, two modes per direction)": zoa.envelope(cfg.structure, cfg.cutting, rpm).depth_mm}
    for label, s in in_process_structures().items():
        curves[label] = zoa.envelope(s, cfg.cutting, rpm).depth_mm
    rows = []
    band = (rpm >= 5500) & (rpm <= 6500)
    for label, d in curves.items():
        rows.append([label, d.min(), rpm[np.argmin(d)], d[band].min(), rpm[band][np.argmin(d[band])]])
    rep.table("fourSLD_summary", ["SLD", "min b_lim [mm] 5000–7000", "at rpm", "min in 5500–6500 [mm]", "at rpm"], rows,
              "Fig. fourSLD curves: where each SLD is lowest")
    return {"rpm": rpm, "curves": curves, "cutting": cfg.cutting}


def stand_in_points(seed: int, noise: float = 0.03, n: int = 21):
    """The synthetic stand-in for the 21 unpublished chatter tests: boundary points of the paper's
    in-process Newton–Raphson result (4103.4 Hz, 11.65 MN/m, 0.0269, axisymmetric) at n evenly spaced
    speeds over 5500–6500 rpm, depths multiplied by (1 + noise·N(0, 1)) with a seeded generator."""
    from millstab.points import PointSet

    pv = paper_values()
    nr = pv["experimental_results"]["newton_raphson"]
    cut = load_example("fourflute").cutting
    rpm = np.linspace(pv["experiment"]["rpm_min"], pv["experiment"]["rpm_max"], n)
    depth = zoa.envelope(Structure.symmetric(nr["fn"], nr["k"], nr["zeta"]), cut, rpm).depth_mm
    rng = np.random.default_rng(seed)
    noisy = depth * (1 + noise * rng.standard_normal(n))
    return PointSet(rpm, noisy, source=f"SYNTHETIC stand-in: NR result + {100 * noise:g} % noise, seed {seed}")


def four_flute(ctx: Context) -> None:
    """Table 4, Fig. fourSLD and the experimental identification (on a stand-in set unless given)."""
    rep = ctx.report
    data = table4(ctx)
    pv = paper_values()
    if ctx.points:
        from millstab.io.points import read_points

        pts = read_points(ctx.points)
        rep.paragraph(f"Identification from the user's measured points {ctx.points} ({len(pts)} rows).")
    else:
        pts = stand_in_points(ctx.seed)
        rep.paragraph(
            f"The paper's experimental data ({pv['experiment']['chatter_tests']} chatter tests of slot milling, "
            f"{pv['experiment']['rpm_min']:g}–{pv['experiment']['rpm_max']:g} rpm, Eynian 2019) are not public in any "
            "source we can reach, so they are NOT reproduced here. Give them with `millstab reproduce --points FILE` "
            "(CSV rpm,depth_mm[,label]). Meanwhile the same identification runs on a SYNTHETIC stand-in: 21 boundary "
            "points over 5500–6500 rpm generated from the paper's in-process Newton–Raphson result with 3 % Gaussian "
            "noise on the depths (red points below). Recovering that result from them shows what the method can do "
            "with 21 noisy points; it says nothing about the real tests.")
    fitted, fit = identify_four_flute(ctx, pts, data)
    plan_next_tests(ctx, fit, pts, data["rpm"])
    from millstab.plot.sld import plot_sld_family

    fig = plot_sld_family(data["rpm"], data["curves"], pts, fitted)
    rep.figure("fig_fourSLD", fig,
               "Fig. fourSLD: the four-flute tool in slotting, static SLD (dashed black) against the "
               "in-process SLDs of the paper and of Eynian's two methods, ours identified from the points (orange), "
               "and the points used for identification (red)")


# --- step 2: Table 3, identification of the synthetic examples ----------------------------------------

#: every parameter starts 30 % away from its target, alternating direction (fn_x +30 %, k_x −30 %, …)
START_FACTORS = np.array([1.3, 0.7, 1.3, 0.7, 1.3, 0.7])
#: the issue's thresholds: our default solver within 0.1 % of every target parameter
LSQ_TOLERANCE = 1e-3


def _identify_example(ctx: Context, ex: str) -> dict:
    from millstab.identify import identify
    from millstab.identify.accuracy import rel_error
    from millstab.identify.symmetry import swap_permutation
    from millstab.identify.synthetic import example_points

    cfg, pts = example_points(ex)
    truth = np.array([_config_value(cfg, n) for n, _, _ in PARAM_ROWS])
    start = truth * START_FACTORS
    initial = {n: v for (n, _, _), v in zip(PARAM_ROWS, start)}
    fits = {m: identify(cfg, pts, method=m, initial=initial, seed=ctx.seed) for m in ("newton", "lsq")}
    perm = swap_permutation(fits["lsq"].par, cfg.cutting)
    errs = {m: rel_error(f.estimate, truth, perm) for m, f in fits.items()}
    return {"cfg": cfg, "points": pts, "truth": truth, "start": start, "fits": fits, "errors": errs}


def table3(ctx: Context) -> None:
    """Table 3: the paper's Newton–Raphson scheme and our default solver on Examples 1–3."""
    rep = ctx.report
    pv = paper_values()["results_fourier"]
    rep.heading("Table 3: identification of the synthetic examples")
    rep.paragraph(
        "Target SLDs: 100 boundary points of each example's true structure at evenly spaced speeds over its "
        "config's [speeds] range (ex1 3000–15000, ex2 1500–9000, ex3 3000–21000 rpm), noise-free, from the zero-order "
        "engine (the paper's speed sets are not given). Every parameter starts 30 % away from its target "
        "(fn_x +30 %, k_x −30 %, ζ_x +30 %, fn_y −30 %, k_y +30 %, ζ_y −30 %). 'newton' is the paper's scheme "
        "(MLAE objective, forward-difference sensitivities, jumps, critical-point weights, diverse initial guesses; "
        "the update applied in log coordinates); 'lsq' is millstab's default (multi-start trust-region least squares). "
        "For the slotting examples x and y are interchangeable (the SLD is symmetric under the swap), so errors "
        "are taken up to that symmetry.")
    results = {}
    rows = []
    for ex in ("ex1", "ex2", "ex3"):
        r = _identify_example(ctx, ex)
        results[ex] = r
        pred = np.array([pv[ex]["predicted"][n] for n, _, _ in PARAM_ROWS])
        paper_err = np.abs(pred / r["truth"] - 1)
        for j, (name, unit, scale) in enumerate(PARAM_ROWS):
            rows.append([ex, f"{name} [{unit}]", r["truth"][j] * scale, r["start"][j] * scale, pred[j] * scale,
                         100 * paper_err[j], r["fits"]["newton"].estimate[j] * scale, 100 * r["errors"]["newton"][j],
                         r["fits"]["lsq"].estimate[j] * scale, 100 * r["errors"]["lsq"][j]])
        nw, ls = r["fits"]["newton"], r["fits"]["lsq"]
        rows.append([ex, "iterations / time [s]", "", "", pv["iterations"], "", f"{nw.iterations} / {nw.time_s:.1f}",
                     "", f"{ls.iterations} / {ls.time_s:.1f}", ""])
        worst_ls = r["errors"]["lsq"].max()
        nw_err = r["errors"]["newton"]
        detail = ", ".join(f"{name} {100 * e:.2f} % (paper {100 * pe:.2f} %)"
                           for (name, _, _), e, pe in zip(PARAM_ROWS, nw_err, paper_err))
        rep.check(f"{ex}: the paper's method (ours) at least as close as the paper's Predicted row in every parameter",
                  detail, bool((nw_err <= paper_err).all()))
        rep.check(f"{ex}: default solver within 0.1 % of every target from a ±30 % start",
                  f"worst error {100 * worst_ls:.4f} %", worst_ls <= LSQ_TOLERANCE)
    rep.table("table3_identification", ["example", "parameter", "target", "start", "paper predicted", "paper error %",
                                        "ours: newton", "newton error %", "ours: lsq", "lsq error %"], rows,
              "Table 3: targets, the paper's Predicted row and ours (k in N/µm)")
    _identification_figures(ctx, results)


def _identification_figures(ctx: Context, results: dict) -> None:
    import matplotlib.pyplot as plt

    from millstab.forward import forward
    from millstab.plot.identify import plot_convergence, plot_final, plot_iterations, snapshot_indices

    rep = ctx.report
    fig, axes = plt.subplots(1, 3, figsize=(15, 3.8))
    for ax, (ex, r) in zip(axes, results.items()):
        plot_convergence(r["fits"]["newton"], ax=ax, title=f"{ex}: Newton–Raphson (paper's scheme)")
    fig.tight_layout()
    rep.figure("fig_conv", fig, "Fig. conv: the objective (MLAE, eq. 4) against iteration, paper's scheme (log scale): "
               "each iterate's MLAE as a dot (the scheme's jumps and trial steps make it zig-zag), the best so far as "
               "a line")

    r3 = results["ex3"]
    fit = r3["fits"]["newton"]
    rpm = np.linspace(r3["points"].rpm.min(), r3["points"].rpm.max(), 400)
    its = snapshot_indices(len(fit.history_mlae), 6)
    guesses = forward(fit.par, r3["cfg"].cutting)(fit.history_theta[its], rpm) * 1e3  # [mm]
    target = zoa.envelope(r3["cfg"].structure, r3["cfg"].cutting, rpm).depth_mm
    rep.figure("fig_iter", plot_iterations(fit, rpm, target, guesses, its),
               "Fig. iter: snapshots of Example 3's guessed SLD (orange) against the target (blue) through the "
               "Newton–Raphson iterations")

    panels = []
    for ex, r in results.items():
        rr = np.linspace(r["points"].rpm.min(), r["points"].rpm.max(), 400)
        tgt = zoa.envelope(r["cfg"].structure, r["cfg"].cutting, rr).depth_mm
        fitted = forward(r["fits"]["newton"].par, r["cfg"].cutting)(r["fits"]["newton"].estimate, rr)[0] * 1e3
        panels.append((f"{ex}: target vs Newton–Raphson result", rr, tgt, fitted, None))
    rep.figure("fig_eggs", plot_final(panels),
               "Fig. eggs: final SLDs of the three examples, the target (blue) against the paper's scheme's result "
               "(orange, dashed)")


# --- step 4: the experimental identification (stand-in) ----------------------------------------------

def identify_four_flute(ctx: Context, pts, data: dict) -> tuple[tuple[str, np.ndarray], object]:
    """Identify the axisymmetric in-process mode from ``pts``, starting from the static dominant mode.

    Returns ((label, depth [mm] of the identified SLD at ``data["rpm"]``), the lsq fit)."""
    import dataclasses

    from millstab.identify import identify

    rep = ctx.report
    pv = paper_values()
    cfg = load_example("fourflute")
    static = cfg.structure.x[int(np.argmax([1 / (m.k * m.zeta) for m in cfg.structure.x]))]
    start_cfg = dataclasses.replace(cfg, structure=Structure.symmetric(static.fn, static.k, static.zeta))
    truth = pv["experimental_results"]["newton_raphson"]
    rows = []
    fits = {}
    for method in ("lsq", "newton"):
        fit = identify(start_cfg, pts, method=method, axisymmetric=True, seed=ctx.seed)
        fits[method] = fit
    lsq = fits["lsq"]
    for j, name in enumerate(lsq.names):
        scale = 1e-6 if name == "k" else 1.0
        se = lsq.std_errors[j] if lsq.std_errors is not None else float("nan")
        row = [name + (" [MN/m]" if name == "k" else " [Hz]" if name == "fn" else ""), getattr(static, name) * scale]
        if not ctx.points:
            row.append(truth[name] * scale)
        row += [fits["newton"].estimate[j] * scale, lsq.estimate[j] * scale, 2 * se * scale]
        if not ctx.points:
            row += [100 * (lsq.estimate[j] / truth[name] - 1), abs(lsq.estimate[j] - truth[name]) <= 2 * se]
        rows.append(row)
    header = ["parameter", "start (static mode 2 of x)"] + ([] if ctx.points else ["truth of the stand-in (paper NR)"])
    header += ["ours: newton", "ours: lsq", "lsq ±2σ"] + ([] if ctx.points else ["lsq error %", "truth inside ±2σ"])
    rep.table("experimental_identification", header, rows,
              "Experimental identification (axisymmetric, one mode): " + (f"from {ctx.points}" if ctx.points else
                                                                          "SYNTHETIC stand-in points"))
    if lsq.warnings:
        rep.paragraph("Solver diagnostics: " + " ".join(lsq.warnings))
    if not ctx.points:
        err_fn = abs(lsq.estimate[0] / truth["fn"] - 1)
        rep.check("Stand-in: fn recovered from 21 points with 3 % noise", f"{100 * err_fn:.2f} % off", err_fn < 0.01)
    depth = zoa.envelope(lsq.structure, cfg.cutting, data["rpm"]).depth_mm
    return ("identified here (lsq" + (", your points)" if ctx.points else ", stand-in points)"), depth), lsq


#: tests the report plans beyond the identification's points, and the depth noise it assumes (that of
#: the stand-in points)
PLAN_TESTS, PLAN_NOISE = 10, 0.03


def plan_next_tests(ctx: Context, fit, pts, rpm: np.ndarray) -> None:
    """Where the next tests should go (not in the paper): :func:`~millstab.identify.design.design_after_fit`
    around the experimental fit, over the speeds of Fig. fourSLD, adding to the points already used."""
    from millstab.identify.design import design_after_fit
    from millstab.plot.identify import plot_design

    rep = ctx.report
    cfg = load_example("fourflute")
    measured = pts.subset(pts.boundary)
    plan = design_after_fit(fit, cfg.cutting, np.linspace(rpm[0], rpm[-1], 800), PLAN_TESTS, existing_rpm=measured.rpm,
                            existing_weight=measured.weight, noise=PLAN_NOISE, seed=ctx.seed)
    rows = [[name, 100 * plan.sigma_existing[i], 100 * plan.sigma_uniform[i], 100 * plan.sigma_design[i]]
            for i, name in enumerate(plan.names)]
    rep.table("test_plan", ["parameter", f"σ % with the {len(measured)} points",
                            f"σ % with {PLAN_TESTS} more evenly spaced", f"σ % with {PLAN_TESTS} more planned"], rows,
              f"Planning the next tests (millstab design; not in the paper): predicted relative standard errors at "
              f"{100 * PLAN_NOISE:g} % depth noise")
    rep.paragraph("Planned speeds [rpm] (tests): " + ", ".join(f"{r:.0f}" + (f" ({c})" if c > 1 else "")
                                                             for r, c, _ in plan.tests()))
    grid = np.linspace(rpm[0], rpm[-1], 800)
    rep.figure("fig_plan", plot_design(plan, grid, zoa.envelope(fit.structure, cfg.cutting, grid).depth_mm, measured),
               "Where to measure next on the four-flute tool: the SLD of the identified mode, the points used (black) "
               "and the tests planned around it (red)")


# --- step 5: Fig. SENS and Table 6 --------------------------------------------------------------------

#: speeds of the sensitivity SLDs: 200 evenly spaced over each example's [speeds] range
SENS_SPEEDS = 200


def _speed_sets() -> dict[str, np.ndarray]:
    """Table 6's two speed sets [rev/min]: A, Example 1's config range; B, a wide range with the tall high-speed
    lobe (the paper does not give its own)."""
    return {"A: ex1 config range 3000–15000 rpm": speeds_of("ex1", SENS_SPEEDS),
            "B: wide range 2000–30000 rpm": np.linspace(2000, 30000, SENS_SPEEDS)}


@dataclass(frozen=True)
class Sensitivity:
    """What :func:`compute_sensitivity` computed, from which :func:`render_sensitivity` and
    :func:`sensitivity_checks` read.

    Attributes:
        oat: (example, :class:`~millstab.sensitivity.results.OATResult`) for each of :data:`EXAMPLES`.
        mc: {speed set: :class:`~millstab.sensitivity.results.MCResult`}, set A first.
        paper: the paper's Table 6 ({parameter: {"mean", "sd"}} [mm²]).
    """

    oat: tuple
    mc: dict
    paper: dict


def compute_sensitivity(quick: bool, seed: int) -> Sensitivity:
    """Fig. SENS's one-at-a-time studies of the three examples and Table 6's Monte Carlo on both speed sets."""
    from millstab.params import Parameterization
    from millstab.sensitivity import PAPER_EPS_GRID, monte_carlo, oat, predicted_theta, table6

    oats = []
    for ex in EXAMPLES:
        cfg = load_example(ex)
        rpm = speeds_of(ex, SENS_SPEEDS)
        oats.append((ex, oat(Parameterization(cfg.structure), cfg.cutting, rpm, PAPER_EPS_GRID,
                             theta=predicted_theta(ex))))
    n = 2000 if quick else 10_000
    cfg = load_example("ex1")
    mcs = {label: monte_carlo(Parameterization(cfg.structure), cfg.cutting, rpm, n=n, t=0.1, eps=0.01, seed=seed,
                              theta=predicted_theta("ex1"))
           for label, rpm in _speed_sets().items()}
    return Sensitivity(tuple(oats), mcs, table6())


def _at_plus20(res) -> np.ndarray:
    """One-at-a-time MSE [mm²] of every parameter at the ε nearest +20 %."""
    return res.mse_mm2[:, np.argmin(np.abs(res.eps - 0.20))]


def sensitivity_checks(r: Sensitivity) -> list:
    """The headline rows: per example, the SLD most sensitive to fn_x and fn_y at +20 %; per speed set, Table 6's
    ordering fn ≫ k > ζ, and the fn_x/k_x ratio beside the paper's (a comparison, no verdict)."""
    from millstab.reproduce.report import Check, comparison

    rows = []
    for ex, res in r.oat:
        at20 = _at_plus20(res)
        order_ok = min(at20[0], at20[3]) > max(at20[1], at20[2], at20[4], at20[5])
        rows.append(Check(f"Fig. SENS {ex}: the SLD is most sensitive to fn_x and fn_y", "MSE at +20 %: " +
                          ", ".join(f"{n} {v:.3g}" for n, v in zip(res.names, at20)), bool(order_ok)))
    paper_ratio = r.paper["fn_x"]["mean"] / r.paper["k_x"]["mean"]
    for label, mc in r.mc.items():
        m = dict(zip(mc.names, mc.mean))
        rows.append(Check(f"Table 6 ({label[0]}): ordering fn ≫ k > ζ in both directions",
                          ", ".join(f"{k} {v:.3g}" for k, v in m.items()),
                          bool(min(m["fn_x"], m["fn_y"]) > 10 * max(m["k_x"], m["k_y"])
                               and min(m["k_x"], m["k_y"]) > max(m["zeta_x"], m["zeta_y"]))))
        # no criterion: the absolute means depend on the (unpublished) speed set, so the ratio is shown, not judged
        rows.append(comparison(f"Table 6 ({label[0]}): mean fn_x / mean k_x sensitivity beside the paper's",
                               m["fn_x"] / m["k_x"], paper_ratio))
    return rows


def render_sensitivity(rep: ReportWriter, r: Sensitivity) -> None:
    """The section: Fig. SENS, its table, Table 6, the convergence figure and :func:`sensitivity_checks`, all from
    ``r`` (no engine call)."""
    from millstab.plot.sensitivity import plot_mc_convergence, plot_oat

    rep.heading("Fig. SENS and Table 6: sensitivity of the SLD")
    rep.paragraph(f"One-at-a-time (Algorithm 1): each parameter scaled by (1 + ε), ε = −20 … +20 % step 5 % (the "
                  f"paper's grid), MSE [mm²] of the SLD against the original at {SENS_SPEEDS} evenly spaced speeds "
                  "over the example's [speeds] range, centred on the paper's predicted values (Table 3), as the paper "
                  "does.")
    oat_rows = []
    for ex, res in r.oat:
        rep.figure(f"fig_sens_{ex}", plot_oat(res),
                   f"Fig. SENS for {ex}: one-at-a-time sensitivity, MSE [mm²] against ε; natural-frequency panels on "
                   "their own scale")
        oat_rows.append([ex] + list(_at_plus20(res)))
    rep.table("fig_sens_mse_at_plus20", ["example", "fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"], oat_rows,
              "Fig. SENS in numbers: MSE [mm²] at ε = +20 %")
    mc = next(iter(r.mc.values()))
    n, paper = mc.n, r.paper
    rep.paragraph(f"Monte Carlo (Algorithm 2): N = {n} paths, each parameter drawn uniformly within ±10 % of Example "
                  f"1's predicted values, then each perturbed by ε = 1 %; MSE [mm²] over {SENS_SPEEDS} evenly spaced "
                  "speeds. The paper does not give its speed set and the absolute MSE depends on it, so two sets are "
                  "shown: A, the range of our Example 1 config, and B, a wide range that includes the tall high-speed "
                  "lobe (with B our means come close to the paper's). The ordering and the ratios are the comparable "
                  "part. SD is the population SD (1/N) as in the paper; SEM is the standard error of our mean.")
    rows = [[label[0], name, paper[name]["mean"], m.mean[j], paper[name]["sd"], m.sd[j], m.sem[j]]
            for label, m in r.mc.items() for j, name in enumerate(m.names)]
    rep.table("table6_monte_carlo",
              ["speed set", "parameter", "paper mean", "ours mean", "paper SD", "ours SD", "ours SEM"],
              rows, f"Table 6: Monte Carlo sensitivity [mm²], N = {n}, speed sets A and B")
    rep.figure("fig_mc_convergence", plot_mc_convergence(mc, paper=paper),
               f"Monte Carlo convergence (speed set A; N = {mc.n}, t = {mc.t:g}, ε = {mc.eps:g}, seed {mc.seed}): "
               "running mean of each parameter's MSE against the number of paths, ±1.96 SEM shaded, the paper's Table "
               "6 value dashed")
    for c in sensitivity_checks(r):
        rep.add(c)


def sensitivity(ctx: Context) -> None:
    """Fig. SENS (one-at-a-time, the three examples at the paper's predicted values) and Table 6."""
    render_sensitivity(ctx.report, compute_sensitivity(ctx.quick, ctx.seed))
