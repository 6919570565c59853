"""``millstab validate``: can I trust it on my machine? Cross-validated scores on the shop's own cuts."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app
from millstab.cli.options import samples_option, seed_option
from millstab.cli.update import LABELS_HELP

_NAMES = {"random": "random folds", "speed": "leave one speed out", "batch": "leave one day (batch) out"}


@app.command("validate")
def validate_cmd(
    config: str = typer.Argument(..., help="TOML config: cutting conditions, hammer-test modes (the prior), optional [prior]."),
    cuts: Path = typer.Argument(..., help="Labelled cuts CSV (as for millstab update)."),
    folds: int = typer.Option(5, "--folds", help="Random folds (and speed bands when there are many speeds)."),
    seed: int = seed_option(0, "Seed of the folds and the updates."),
    samples: int = samples_option(1000, "Posterior samples per fold's update."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine of the updates: {', '.join(ENGINES)}."),
    labels: Optional[str] = typer.Option(None, "--labels", help=LABELS_HELP),
    batch_effect: Optional[str] = typer.Option(None, "--batch-effect", help="σ of a test day's shift of every natural "
                                               "frequency in the updates, e.g. 3% (as update --batch-effect)."),
    out: Optional[Path] = typer.Option(None, "--out", help="JSON: the scores per scheme and method, folds, predictions."),
    predictions: Optional[Path] = typer.Option(None, "--predictions", help="CSV: each cut's held-out predictions."),
) -> None:
    """Cross-validated Brier, log loss and AUC of millstab beside the majority rate, logistic regression and kNN."""
    from rich.console import Console
    from rich.table import Table

    from millstab import api
    from millstab.api.validate import validate
    from millstab.io import check_outputs, config_inputs, read_points, write_csv, write_json

    cfg = api.with_batch_effect(api.config(config), batch_effect)
    c = read_points(cuts, labels)
    inputs = {**config_inputs(cfg), "CUTS": cuts}
    check_outputs(inputs, {"--out": out, "--predictions": predictions})  # before the work
    protect = [v for v in inputs.values() if v]
    con = Console()
    with con.status("updating on each fold ...") as status:
        res = validate(cfg, c, folds=folds, seed=seed, samples=samples, engine=engine,
                       progress=lambda stage, done, total: status.update(f"{stage}: {done}/{total} updates"))
    for s, rows in res.summary.items():
        t = Table(title=f"{_NAMES[s]} ({len(rows['millstab']['fold_brier'])} folds, {rows['millstab']['n']} cuts)",
                  caption="Brier against the graded label (lower is better); log loss and AUC against chatter "
                          "(grade > 1/2), marginal cuts left out")
        for col in ("method", "Brier", "log loss", "AUC", "Brier per fold (min-max)"):
            t.add_column(col, justify="left" if col == "method" else "right")
        best = min(r["brier"] for r in rows.values())
        for m, r in rows.items():
            fb = r["fold_brier"]
            mark = " *" if r["brier"] <= best else ""
            t.add_row(m, f"{r['brier']:.4f}{mark}", f"{r['log_loss']:.3f}", f"{r['auc']:.3f}", f"{min(fb):.3f}-{max(fb):.3f}")
        con.print(t)
    for note in res.notes:
        con.print(f"[yellow]note:[/yellow] {note}")
    if out:
        write_json(out, res.to_json(), protect=protect)
        con.print(f"wrote {out}")
    if predictions:
        write_csv(predictions, *res.table(), protect=protect)
        con.print(f"wrote {predictions}")
