"""``millstab recommend``: the most productive cut at a chatter risk, and the next test cut."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.history import CampaignOpt, ShopDbOpt, UserOpt, posterior_source, shop_target
from millstab.cli.options import (EngineOptionOpt, EntryDegOpt, ExitDegOpt, MillingOpt, RadialImmersionOpt,
                                  StickoutOpt, TeethOpt, for_decision, seed_option)

#: = millstab.update.decide.TEST_RISK (not imported: the command line starts without numba; a test checks they agree)
TEST_RISK = 0.5


@app.command("recommend")
def recommend_cmd(
    posterior: Optional[Path] = typer.Argument(None, help="Posterior JSON from millstab update (or --db/--campaign)."),
    risk: float = typer.Option(0.05, "--risk", help="Tolerated probability of chatter, in (0, 1)."),
    rpm: str = typer.Option(..., "--rpm", help="Speed range LOW:HIGH [rpm]."),
    max_depth: Optional[float] = typer.Option(None, "--max-depth", help="Deepest allowed cut [mm]."),
    radial_width: Optional[float] = typer.Option(
        None, "--radial-width", rich_help_panel="Target condition",
        help="Radial width of cut [mm]. With the config's tool diameter it sets the decision's a/D (width/diameter, "
             "with --milling or the posterior's direction; given with --radial-immersion or --entry-deg/--exit-deg it "
             "must agree with them) and, with --feed-per-tooth, the cm³/min; without a diameter it is for the "
             "cm³/min only (the condition is the other options', else the posterior's)."),
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
    confirm: str = typer.Option("auto", "--confirm",
                                help="When the recommendation must be no deeper than a cut labelled stable that the "
                                     "posterior holds safe, within ±2 % of its speed: 'auto' (as 'conflict' unless "
                                     "two or more chatter cuts carry frequencies that place the modes), 'conflict' "
                                     "(while the cuts contradict the hammer test), 'always', 'never'."),
    discriminate: str = typer.Option("never", "--discriminate",
                                     help="'conflict': while the cuts contradict the hammer test, the next test is "
                                          "the cut that best tells the posterior from the far-off alternative the "
                                          "cuts fit best (experimental); 'gain': while they contradict it, the "
                                          "cut whose label is expected to raise the recommendation most; 'never': "
                                          "the most informative cut."),
    search: str = typer.Option("auto", "--search",
                               help="The speed search: 'full' (every posterior sample at every speed), 'fast' (a "
                                    "subsample finds the pockets, every sample sets the depth: the same risk), "
                                    "'auto' (fast for engines other than zoa)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Recommendation JSON (optional: the summary is printed)."),
    stickout: StickoutOpt = None,
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    user: UserOpt = None,
    radial_immersion: RadialImmersionOpt = None,
    milling: MillingOpt = None,
    entry_deg: EntryDegOpt = None,
    exit_deg: ExitDegOpt = None,
    teeth: TeethOpt = None,
    options: EngineOptionOpt = None,
) -> None:
    """The most productive cut whose probability of chatter is at most RISK, and the next test cut."""
    from rich.console import Console

    from millstab import api
    from millstab.cli import emit

    span, rule = api.decision_rule(risk, rpm, confidence=confidence, speed_tolerance=speed_tolerance,
                                   test_risk=test_risk, max_depth_mm=max_depth, width_mm=radial_width,
                                   feed_mm=feed_per_tooth, seed=seed, confirm=confirm,
                                   discriminate=discriminate, search=search)
    post, inputs, pid = posterior_source(posterior, db, campaign, user)
    post = for_decision(post, stickout, radial_immersion, milling, entry_deg, exit_deg, teeth, options, radial_width)
    protect = emit.checked(inputs, {"--out": out})
    if shop_target(db, campaign):  # the campaign's current posterior, read once; the recommendation is recorded there
        from millstab.api.shop import recommend_from_db

        rec = recommend_from_db(db, campaign, risk, span, user=user, current=(pid, post), **rule)[0]
    else:
        rec = api.recommend(post, risk, span, **rule)
    con = Console()
    emit.json(out, rec.to_json(), protect, lambda line: None)
    # the update's own warnings (a prior-data conflict among them) belong to every decision
    emit.warnings(con, post.warnings, "warning (from the update)")
    con.print(api.condition_line(post))
    con.print(rec.summary())
    if out:
        con.print(f"wrote {out}")
