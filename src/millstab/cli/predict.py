"""``millstab predict``: per cut, the chance that it is stable and that an operator writes "chatter"."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.update import LABELS_HELP, _load_posterior


@app.command("predict")
def predict_cmd(
    posterior: Path = typer.Argument(..., help="Posterior JSON from millstab update."),
    cuts: Path = typer.Argument(..., help="Cuts CSV rpm,depth_mm[,label...] to predict (labels, if any, are scored)."),
    out: Path = typer.Option(..., "--out", help="CSV rpm,depth_mm[,label],p_stable,p_label_chatter, in the input order."),
    labels: Optional[str] = typer.Option(None, "--labels", help=LABELS_HELP),
) -> None:
    """P(stable) (the process) and P(label chatter) (what an operator will write) for each cut of CUTS."""
    from rich.console import Console

    from millstab.api.predict import predict
    from millstab.io import check_outputs, read_points, write_csv

    c = read_points(cuts, labels)
    check_outputs({"POSTERIOR": posterior, "CUTS": cuts}, {"--out": out})  # before the work
    post = _load_posterior(posterior)
    pred = predict(post, c)
    write_csv(out, *pred.table(), protect=[posterior, cuts])
    con = Console()
    for w in pred.warnings:
        con.print(f"[yellow]warning (from the update):[/yellow] {w}")
    con.print(f"{len(c)} cuts: P(stable) {pred.p_stable.min():.3f}-{pred.p_stable.max():.3f}" if len(c) else "no cuts")
    s = pred.scores()
    if s is not None:
        con.print(f"  against the {s['n']} labelled cuts: Brier score {s['brier']:.4f} (their own chatter rate as a "
                  f"constant: {s['brier_rate']:.4f}); for held-out scores use millstab validate")
    con.print(f"wrote {out}")
