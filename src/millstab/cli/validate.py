"""``millstab validate``: can I trust it on my machine? Cross-validated scores on the shop's own cuts."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app
from millstab.cli.options import EngineOptionOpt, engine_option_pairs, samples_option, seed_option
from millstab.cli.update import LABELS_HELP


@app.command("validate")
def validate_cmd(
    config: str = typer.Argument(...,
                                 help="TOML config: cutting conditions, hammer-test modes (the prior), optional "
                                      "[prior]."),
    cuts: Path = typer.Argument(..., help="Labelled cuts CSV (as for millstab update)."),
    folds: int = typer.Option(5, "--folds", help="Random folds (and speed bands when there are many speeds)."),
    seed: int = seed_option(0, "Seed of the folds and the updates."),
    samples: int = samples_option(1000, "Posterior samples per fold's update."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine of the updates: {', '.join(ENGINES)}."),
    labels: Optional[str] = typer.Option(None, "--labels", help=LABELS_HELP),
    batch_effect: Optional[str] = typer.Option(None, "--batch-effect", help="σ of a test day's shift of every natural "
                                               "frequency in the updates, e.g. 3% (as update --batch-effect)."),
    out: Optional[Path] = typer.Option(None, "--out",
                                       help="JSON: the scores per scheme and method, folds, predictions."),
    predictions: Optional[Path] = typer.Option(None, "--predictions", help="CSV: each cut's held-out predictions."),
    options: EngineOptionOpt = None,
) -> None:
    """Cross-validated Brier, log loss and AUC of millstab beside the majority rate, logistic regression and kNN."""
    from rich.console import Console

    from millstab import api
    from millstab.api.validate import validate
    from millstab.cli import emit
    from millstab.io import config_inputs, read_points

    cfg = api.with_batch_effect(api.config(config), batch_effect)
    c = read_points(cuts, labels)
    protect = emit.checked({**config_inputs(cfg), "CUTS": cuts}, {"--out": out, "--predictions": predictions})
    con = Console()
    with con.status("updating on each fold ...") as status:
        res = validate(cfg, c, folds=folds, seed=seed, samples=samples, engine=engine,
                       engine_options=engine_option_pairs(options),
                       progress=lambda stage, done, total: status.update(f"{stage}: {done}/{total} updates"))
    for title, header, rows, caption in res.score_tables():
        emit.table(con, title, header, rows, caption)
    emit.warnings(con, res.notes, "note")
    emit.json(out, res.to_json, protect, con.print)
    emit.csv(predictions, predictions and res.table(), protect, con.print)
