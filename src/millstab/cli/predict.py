"""``millstab predict``: per cut, the chance that it is stable and that an operator writes "chatter"."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab import api
from millstab.cli import emit
from millstab.cli.app import app
from millstab.cli.history import CampaignOpt, ShopDbOpt, posterior_source
from millstab.cli.options import (EngineOptionOpt, EntryDegOpt, ExitDegOpt, MillingOpt, RadialImmersionOpt,
                                  RadialWidthOpt, StickoutOpt, TeethOpt, for_decision)
from millstab.cli.update import LABELS_HELP
from millstab.errors import InputError


@app.command("predict")
def predict_cmd(
    posterior: Path = typer.Argument(...,
                                     help="Posterior JSON from millstab update (with --db/--campaign: leave it out "
                                          "and give CUTS alone)."),
    cuts: Optional[Path] = typer.Argument(None, help="Cuts CSV rpm,depth_mm[,label...] to predict (labels, if any, are "
                                                     "scored)."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV: every column of CUTS as read (labels, notes, "
                                                           "conditions, ...), in the input order, then "
                                                           "p_stable,p_label_chatter (and condition where the cuts' "
                                                           "conditions differ, condition_note where one was never "
                                                           "cut); without --out and --json the table is printed."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="The predictions as JSON (schema "
                                                                 "millstab.prediction/1: the cuts, p_stable, "
                                                                 "p_label_chatter, the warnings, the "
                                                                 "condition per cut, config and points); with or "
                                                                 "instead of --out."),
    labels: Optional[str] = typer.Option(None, "--labels", help=LABELS_HELP),
    stickout: StickoutOpt = None,
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    radial_immersion: RadialImmersionOpt = None,
    milling: MillingOpt = None,
    entry_deg: EntryDegOpt = None,
    exit_deg: ExitDegOpt = None,
    teeth: TeethOpt = None,
    radial_width: RadialWidthOpt = None,
    options: EngineOptionOpt = None,
) -> None:
    """P(stable) (the process) and P(label chatter) (what an operator will write) for each cut of CUTS."""
    from rich.console import Console

    from millstab.api.predict import predict
    from millstab.io import read_points

    if cuts is None and db is not None:  # `predict --db X --campaign C cuts.csv`: the one argument is the cuts
        posterior, cuts = None, posterior
    if cuts is None:
        raise InputError("CUTS", None, "missing: the cuts CSV to predict")
    c = read_points(cuts, labels)
    post, inputs, _ = posterior_source(posterior, db, campaign)
    post = for_decision(post, stickout, radial_immersion, milling, entry_deg, exit_deg, teeth, options, radial_width)
    protect = emit.checked({**inputs, "CUTS": cuts}, {"--out": out, "--json": json_out})  # before the work
    pred = predict(post, c)
    con = Console()
    emit.warnings(con, pred.warnings, "warning (from the update)")  # the prediction's own were printed as issued
    con.print(api.condition_line(post) if pred.condition is None else "computed per cut for the condition in its "
                                                                   "'condition' column")
    con.print(pred.summary())
    emit.csv_or_print(out, pred.table(), protect, con.print, printed=json_out is None)  # as simulate: no --out
    emit.json(json_out, pred.to_json, protect, con.print)
