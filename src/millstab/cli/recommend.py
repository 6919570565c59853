"""``millstab recommend``: the most productive cut at a chatter risk, and the next test cut."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.options import seed_option
from millstab.cli.options import (EntryDegOpt, ExitDegOpt, MillingOpt, RadialImmersionOpt, StickoutOpt, TeethOpt,
                                  for_decision)
from millstab.cli.history import CampaignOpt, ShopDbOpt, UserOpt, posterior_source, shop_target
from millstab.errors import InputError

#: = millstab.update.decide.TEST_RISK (not imported: the command line starts without numba; a test checks they agree)
TEST_RISK = 0.5


def _confidence(text: str) -> float | None:
    """--confidence as a number in [0.5, 1), or None for 'none'."""
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.5 <= value < 1:
        raise InputError("--confidence", text, "a one-sided confidence in [0.5, 1), e.g. 0.9, or 'none'")
    return value


@app.command("recommend")
def recommend_cmd(
    posterior: Optional[Path] = typer.Argument(None, help="Posterior JSON from millstab update (or --db/--campaign)."),
    risk: float = typer.Option(0.05, "--risk", help="Tolerated probability of chatter, in (0, 1)."),
    rpm: str = typer.Option(..., "--rpm", help="Speed range LOW:HIGH [rpm]."),
    max_depth: Optional[float] = typer.Option(None, "--max-depth", help="Deepest allowed cut [mm]."),
    radial_width: Optional[float] = typer.Option(None, "--radial-width", help="Radial width of cut [mm] (for cm³/min)."),
    feed_per_tooth: Optional[float] = typer.Option(None, "--feed-per-tooth", help="Feed per tooth [mm] (for cm³/min)."),
    seed: int = seed_option(0, "Seed of the next-test subsample."),
    test_risk: float = typer.Option(TEST_RISK, "--test-risk",
                                    help="The proposed next test's probability of chatter is at most this, in (0, 1] "
                                         "(a chattering test costs a part or a tool; 1: no cap)."),
    confidence: str = typer.Option("0.9", "--confidence",
                                   help="P(chatter) <= RISK must hold with this one-sided confidence against the "
                                        "posterior's sampling error, in [0.5, 1); 'none': the plain sample count."),
    speed_tolerance: float = typer.Option(0.0025, "--speed-tolerance",
                                          help="Relative spindle-speed error the cut must tolerate, in [0, 0.1) "
                                               "(0.0025 = ±0.25 %)."),
    out: Path = typer.Option(..., "--out", help="Recommendation JSON."),
    stickout: StickoutOpt = None,
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    user: UserOpt = None,
    radial_immersion: RadialImmersionOpt = None,
    milling: MillingOpt = None,
    entry_deg: EntryDegOpt = None,
    exit_deg: ExitDegOpt = None,
    teeth: TeethOpt = None,
) -> None:
    """The most productive cut whose probability of chatter is at most RISK, and the next test cut."""
    from rich.console import Console

    from millstab import api
    from millstab.io import check_outputs, write_json

    if not 0 < risk < 1:  # before reading the posterior: the cheapest error first
        raise InputError("--risk", risk, "the tolerated probability of chatter must be in (0, 1), e.g. 0.05")
    lo, hi = api.parse_interval(rpm, "--rpm", "rpm", positive=True)
    conf = _confidence(confidence)
    if not (math.isfinite(speed_tolerance) and 0 <= speed_tolerance < 0.1):
        raise InputError("--speed-tolerance", speed_tolerance, "a relative spindle-speed error in [0, 0.1), e.g. 0.0025")
    if not (math.isfinite(test_risk) and 0 < test_risk <= 1):
        raise InputError("--test-risk", test_risk, f"the next test's tolerated probability of chatter, in (0, 1], e.g. "
                                                   f"{TEST_RISK:g} (1: no cap)")
    rule = dict(max_depth_mm=max_depth, width_mm=radial_width, feed_mm=feed_per_tooth, seed=seed, confidence=conf,
                speed_tolerance=speed_tolerance, test_risk=test_risk)
    post, inputs, pid = posterior_source(posterior, db, campaign, user)
    post = for_decision(post, stickout, radial_immersion, milling, entry_deg, exit_deg, teeth)
    check_outputs(inputs, {"--out": out})
    if shop_target(db, campaign):  # the campaign's current posterior, read once; the recommendation is recorded there
        from millstab.api.shop import recommend_from_db

        rec = recommend_from_db(db, campaign, risk, (lo, hi), user=user, current=(pid, post), **rule)[0]
    else:
        rec = api.recommend(post, risk, (lo, hi), **rule)
    write_json(out, rec.to_json(), protect=list(inputs.values()))
    con = Console()
    for w in post.warnings:  # the update's own warnings (a prior-data conflict among them) belong to every decision
        con.print(f"[yellow]warning (from the update):[/yellow] {w}")
    mrr = f", {rec.mrr_cm3_per_min:.4g} cm³/min" if rec.mrr_cm3_per_min is not None else ""
    con.print(api.condition_line(post))
    con.print(f"recommended: {rec.rpm:.0f} rpm, {rec.depth_mm:.3f} mm (P(chatter) {rec.p_chatter:.3f} ≤ {risk:g}, "
              f"limited by {rec.limited_by}{mrr})")
    if rec.p_chatter_bound is not None:
        con.print(f"  held at ±{100 * rec.speed_tolerance:g} % speed error (P(chatter) ≤ {rec.p_chatter_speed_error:.3f}) "
                  f"and against the sampling error: {rec.confidence:.0%} upper bound {rec.p_chatter_bound:.3f} from "
                  f"{rec.effective_samples:.0f} effective samples")
    for g in rec.guard:
        if g["binding"]:
            con.print(f"  data guard: held below {g['cap_mm']:.3g} mm within ±{g['half_width_rpm']:.0f} rpm of a cut labelled "
                      f"chatter at {g['rpm']:.0f} rpm, {g['depth_mm']:.3g} mm")
    nt = rec.next_test
    con.print(f"next test: {nt['rpm']:.0f} rpm, {nt['depth_mm']:.3f} mm (P(chatter) {nt['p_chatter']:.2f}; {nt['why']})")
    con.print(f"wrote {out}")
