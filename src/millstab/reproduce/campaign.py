"""Beyond the paper: a virtual test campaign, from a hammer test to a decision (issue 17).

The shop's loop, played against a truth the tool does not know (:func:`millstab.update.campaign.run_campaign`):
the prior is the seed paper's Example 1 hammer test (default spreads: fn 5 %, k 30 %, ζ 30 %); the
truth is that structure off by a random factor per parameter (uniform in fn ±3 %, k ±20 %, ζ ±30 %,
drawn with the run's seed); a cut chatters when its depth exceeds the true zero-order limit times
exp(ε), ε ~ N(0, 3 %) (label noise). The first cut is the prior's own recommendation at a 5 % risk,
each later one the tool's next test; after every cut the posterior is updated (tempered SMC,
sequential reuse) and the recommendation judged against the truth. ``--quick`` uses fewer posterior
samples (the loop is the same).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the campaign's constraints: speed range [rpm], deepest cut [mm], risk, number of test cuts
RPM = (5000.0, 12000.0)
MAX_DEPTH_MM = 8.0
RISK = 0.05
CUTS = 10
#: posterior samples (full run / --quick)
SAMPLES = {False: 2000, True: 400}
#: how far the in-process truth is from the hammer test (uniform ± fraction per kind), and the label noise
OFF = {"fn": 0.03, "k": 0.20, "zeta": 0.30}
LABEL_NOISE = 0.03
#: the maps shown: after these numbers of cuts
SHOWN = (0, 3, 10)


@dataclass(frozen=True)
class VirtualCampaign:
    """What :func:`play` computed, from which :func:`render` writes the section and :func:`checks` the
    headline rows (no engine call after it).

    Attributes:
        campaign: the record (:class:`millstab.update.campaign.Campaign`).
        names, off: the free parameters and how far the truth is from the hammer test (fractions).
        samples, quick: posterior samples per update, and whether it was the --quick run.
        rpm, depth: the maps' grid [rpm], [mm]; maps: P(stable) (rpm, depth) after the cuts of :data:`SHOWN`.
        true_sld, prior_sld: the true limit and the hammer-test SLD on ``rpm`` [mm].
        final_true_mm: the true limit at the final recommendation's speed [mm].
        ham_rpm, ham_mm, ham_ok, ham_p: the hammer test's own cut (its most productive point 5 % below its SLD),
            whether it is truly stable, and its productivity over the best truly stable cut's.
    """

    campaign: object
    names: tuple[str, ...]
    off: np.ndarray
    samples: int
    quick: bool
    rpm: np.ndarray
    depth: np.ndarray
    maps: dict
    true_sld: np.ndarray
    prior_sld: np.ndarray
    final_true_mm: float
    ham_rpm: float
    ham_mm: float
    ham_ok: bool
    ham_p: float

    @property
    def reached(self) -> int | None:
        """After how many cuts the recommendation was first truly stable at ≥ 85 % of the best (None: never)."""
        c = self.campaign
        return next((k for k in range(CUTS + 1) if c.rec_stable[k] and c.rec_productivity[k] >= 0.85), None)

    @property
    def final_exact(self) -> float:
        """The final recommendation's productivity over the exact best's (no speed tolerance)."""
        c = self.campaign
        return c.rec_rpm[-1] * c.rec_depth_mm[-1] / c.best_exact


def play(seed: int, quick: bool) -> VirtualCampaign:
    """Play the section's campaign (module docstring) with the run's ``seed``: the computation, apart from
    its prose (:func:`render`) and checks (:func:`checks`)."""
    from millstab.io import load_config
    from millstab.io.config import PriorTable
    from millstab.stability import engine_with
    from millstab.update import make_prior, p_stable_map
    from millstab.update.campaign import CampaignOptions, run_campaign

    cfg = load_config("example:ex1")
    # the likelihood's depth noise told the virtual shop's label scatter, as a shop would set [prior] sigma_depth
    prior = make_prior(cfg.structure, cfg.cutting, PriorTable({}, sigma_depth_rel=LABEL_NOISE))
    zoa = engine_with(cheap=True)  # the virtual shop's truth: the cheapest engine (zoa)
    rng = np.random.default_rng([seed, 17])
    off = np.array([rng.uniform(-OFF[prior.par.kind(n)], OFF[prior.par.kind(n)]) for n in prior.par.free])
    theta = prior.median * (1 + off)
    s_true = prior.par.structure(theta)

    def truth(rpm):
        return zoa.envelope(s_true, cfg.cutting, np.asarray(rpm, float)).depth_mm

    def labeler(rpm, depth, r):
        edge = truth(rpm) * np.exp(LABEL_NOISE * r.standard_normal(np.shape(rpm)))
        return list(np.where(depth > edge, "chatter", "stable")), [float("nan")] * np.size(rpm)

    g_rpm, g_depth = np.linspace(*RPM, 61), np.linspace(0.05, MAX_DEPTH_MM, 40)
    grid = (g_rpm, g_depth, g_depth[None, :] < truth(g_rpm)[:, None])
    n = SAMPLES[quick]
    opts = CampaignOptions(cuts=CUTS, samples=n, risk=RISK, rpm_range=RPM, max_depth_mm=MAX_DEPTH_MM,
                           seed=int(rng.integers(2**31)), keep=SHOWN)
    camp = run_campaign(cfg, prior, truth, labeler, opts, truth_grid=grid)
    # the hammer test alone: the most productive point 5 % below its own SLD
    fine = np.linspace(*RPM, 361)
    b_ham = zoa.envelope(cfg.structure, cfg.cutting, fine).depth_mm
    j = int(np.argmax(np.minimum(0.95 * b_ham, MAX_DEPTH_MM) * fine))
    d_ham = min(0.95 * b_ham[j], MAX_DEPTH_MM)
    rpm = np.linspace(*RPM, 141)
    depth = np.linspace(0.0, MAX_DEPTH_MM, 121)
    return VirtualCampaign(
        camp, tuple(prior.names), off, n, quick, rpm, depth,
        {k: p_stable_map(camp.posteriors[k], rpm, depth) for k in SHOWN},
        truth(rpm), zoa.envelope(cfg.structure, cfg.cutting, rpm).depth_mm, float(truth([camp.rec_rpm[-1]])[0]),
        float(fine[j]), float(d_ham), bool(d_ham < truth([fine[j]])[0]), float(fine[j] * d_ham / camp.best))


def checks(v: VirtualCampaign) -> list:
    """The section's headline rows (:class:`millstab.reproduce.report.Check`), from the played campaign alone."""
    from millstab.reproduce.report import Check

    camp = v.campaign
    fin_ok, fin_p = camp.rec_stable[-1], camp.rec_productivity[-1]
    # one campaign is an anecdote: "≥ 85 % of the best after 10 cuts" holds in most campaigns, not all (34 of 40
    # calibration campaigns with the default --test-risk 0.5, docs/updating.md), so it is reported, not checked;
    # what one campaign must show is that the cuts paid
    p0 = camp.rec_productivity[0] if camp.rec_stable[0] else 0.0
    return [
        Check(f"Virtual campaign: after {CUTS} tool-chosen cuts the recommendation at risk {RISK:g} is truly stable",
              f"{camp.rec_rpm[-1]:.0f} rpm, {camp.rec_depth_mm[-1]:.2f} mm, true limit {v.final_true_mm:.2f} mm",
              bool(fin_ok)),
        Check(f"Virtual campaign: after {CUTS} cuts the truly stable recommendation is more productive than the one "
              "from the hammer test alone (0 cuts; a chattering one counts as 0)",
              f"{p0:.2f} → {fin_p:.2f} of the best truly stable cut (±0.25 % speed error; of the exact best: "
              f"{v.final_exact:.2f}); ≥ 85 % {'reached' if fin_p >= 0.85 else 'not reached'} in this campaign",
              bool(fin_ok and fin_p > p0)),
        Check("Virtual campaign: the P(stable) map's Brier score after the cuts beats the prior's",
              f"{camp.brier[0]:.4f} → {camp.brier[-1]:.4f}", bool(camp.brier[-1] < camp.brier[0])),
    ]


def virtual_campaign(ctx) -> None:
    """One virtual campaign: P(stable) maps after 0, 3 and 10 cuts, the cuts-to-optimum curve, a table."""
    render(ctx.report, play(ctx.seed, ctx.quick))


def render(rep, v: VirtualCampaign) -> None:
    """The section of the report (``rep``: a :class:`millstab.reproduce.report.ReportWriter`): prose, table,
    figure and :func:`checks`, all from the played campaign ``v``."""
    from millstab.plot.update import plot_campaign

    camp, n, rpm, depth = v.campaign, v.samples, v.rpm, v.depth
    rep.heading("Beyond the paper: from a hammer test and test cuts to a decision (Bayesian updating)")
    off_txt = ", ".join(f"{nm} {100 * f:+.0f} %" for nm, f in zip(v.names, v.off))
    rep.paragraph(
        "A shop runs a few test cuts, writes down whether each chattered, and asks where it can cut with at most "
        f"a {RISK:.0%} chance of chatter. millstab update turns a hammer-test prior and labelled cuts into posterior "
        "samples of the modal parameters (tempered sequential Monte Carlo through the batched zero-order engine; "
        "probit likelihood); millstab map gives P(stable) on a speed × depth "
        "grid; millstab recommend gives the most productive cut whose P(chatter) ≤ risk and the next test (the "
        "largest expected information about the parameters, weighted by productivity). Here the loop is played "
        f"against a virtual machine: prior = Example 1's hammer test (2 teeth, slotting); truth = that structure "
        f"off by {off_txt} (in-process dynamics differ from a tap test); a cut chatters when it is deeper than the "
        f"true zero-order limit × exp(ε), ε ~ N(0, {LABEL_NOISE:.0%}), and the likelihood is told so ([prior] "
        f"sigma_depth = \"{LABEL_NOISE:.0%}\"; with the default 0.05 mm, a third of this scatter at 5 mm, the "
        "likelihood would trust the labels of cuts near the boundary too much and the posterior would be overconfident "
        f"there). Speeds {RPM[0]:.0f}–{RPM[1]:.0f} rpm, depth "
        f"at most {MAX_DEPTH_MM:g} mm, {CUTS} cuts, {n} posterior samples"
        + (" (--quick; the full run uses " + str(SAMPLES[False]) + ")" if v.quick else "") + ".")
    recs = {k: (camp.rec_rpm[k], camp.rec_depth_mm[k]) for k in SHOWN}
    cuts = {"rpm": camp.cut_rpm, "depth_mm": camp.cut_depth_mm, "label": camp.labels}
    rows = [[k, camp.labels[k - 1] if k else "–", camp.rec_rpm[k], camp.rec_depth_mm[k],
             "yes" if camp.rec_stable[k] else "NO (chatters)", camp.rec_productivity[k], camp.brier[k]]
            for k in range(CUTS + 1)]
    rep.table("campaign", ["cuts", "label of the last cut", "recommended rpm", "recommended depth [mm]", "truly stable",
                           "productivity / best", "Brier score of the map"], rows,
              f"The virtual campaign cut by cut: the recommendation at risk {RISK:g} after k cuts, judged against the "
              "truth; productivity = depth × speed over that of the best truly stable cut under the same constraints "
              "(stable also at ±0.25 % spindle-speed error, as the recommendation must be); Brier score = mean squared "
              "difference between P(stable) and the true 0/1 stability on a 61 × 40 grid")
    reached, fin_exact = v.reached, v.final_exact
    fin_ok, fin_p = camp.rec_stable[-1], camp.rec_productivity[-1]
    rep.figure("fig_campaign", plot_campaign(rpm, depth, v.maps, v.true_sld, cuts, recs,
                                             np.array(camp.rec_productivity), np.array(camp.rec_stable), v.prior_sld),
               f"A virtual campaign: P(stable) after {', '.join(map(str, SHOWN))} cuts (colour; 5/50/95 % contours "
               "black; the true limit solid blue, the hammer-test SLD dotted; the cuts made so far and the "
               "recommendation, a gold star) and the cuts-to-optimum curve (the recommendation's productivity over "
               "the best truly stable cut's after each cut)")
    n_ok = sum(camp.rec_stable)
    rep.paragraph(
        f"Measured in this run: from the hammer test alone (0 cuts) the recommendation is "
        f"{'truly stable' if camp.rec_stable[0] else 'a chattering cut'} at {camp.rec_productivity[0]:.2f} of the "
        f"best; after {CUTS} tool-chosen cuts it is {'truly stable' if fin_ok else 'a chattering cut'} at {fin_p:.2f} "
        f"of the best ({camp.rec_rpm[-1]:.0f} rpm, {camp.rec_depth_mm[-1]:.2f} mm; {fin_exact:.2f} of the exact best, "
        f"which sits on a pocket's cusp that no cut tolerating a speed error can use); "
        + (f"85 % of the best was first reached, stably, after {reached} cuts; " if reached is not None else
           "85 % of the best was not reached stably; ")
        + f"{n_ok} of the {CUTS + 1} recommendations along the way were truly stable. The map's Brier score went "
        f"{camp.brier[0]:.4f} → {camp.brier[3]:.4f} → {camp.brier[-1]:.4f} (0, 3, {CUTS} cuts). The hammer-test "
        f"SLD alone (its most productive point 5 % below its own limit) would cut at {v.ham_rpm:.0f} rpm, "
        f"{v.ham_mm:.2f} mm: "
        f"{'truly stable' if v.ham_ok else 'it chatters'} ({v.ham_p:.2f} of the best). Each update after the first "
        f"started from the previous posterior and took {min(camp.stages)}–{max(camp.stages)} tempering stages. "
        "One campaign is an anecdote. The decision rule holds P(chatter) ≤ risk with 90 % confidence against the "
        "Monte Carlo error of its estimate (a Clopper–Pearson bound over the posterior's effective sample size) "
        "and at ±0.25 % of the spindle speed (the best speed is a pocket's cusp, a knife-edge), and the "
        "likelihood allows a swapped label with probability 0.02. Measured with "
        "benchmarks/bench_update_campaign.py, not in this run (docs/updating.md has the tables and the commands): "
        "over 100 calibration campaigns (--calibrate: truth drawn from the prior, labels from the likelihood's own "
        "noise model, 1 000 samples) the recommendation after 10 cuts was truly stable in 98, at a median 0.93 of "
        "the best truly stable cut's productivity (≥ 0.85 and stable in 77), the 90 % intervals covered the truth "
        "in 86–92 % per parameter and the Brier score beat the prior's in 91 (measured with the Gaussian prior "
        "and no cap on the next test's risk; with the default cap --test-risk 0.5, 40 campaigns of 500 samples: "
        "all 40 stable, median 0.94, ≥ 0.85 and stable in 34, the tests that chattered down from 57 % to 45 %; "
        "with the default Student-t prior, 12 campaigns: 12 stable, median 0.91); from the hammer-test SLD alone 14 "
        "of 100 were stable, after ten evenly spaced cuts 93 at a median 0.67. With labels from the time-domain "
        "simulation and a hammer test off the truth (25 slotting campaigns) 25 were stable at a median 0.94 "
        "(the hammer-test SLD alone: 5). With model error (a/D 0.1, the same simulated labels, 50 campaigns "
        "updated with zoa) 48 of 50 were stable at a median 0.99 (≥ 0.85 in 44); the true structure under zoa "
        "contradicted 97 of the 410 labels, under the interrupted-cutting spectral engine 30 (the operator's "
        "5 % swapped labels among them), and its 90 % interval of the limit covered the true limit at 78 % of "
        "the cut speeds; updated with the spectral engine (10 of those campaigns, 500 samples, 13 min each) all "
        "10 were stable at a median 0.85, its interval covering the true limit at 94 % of the cut speeds.")
    for c in checks(v):
        rep.add(c)


__all__ = ["VirtualCampaign", "checks", "play", "render", "virtual_campaign"]
