"""``millstab campaign list|export|import``: the campaigns of a shop database, and a campaign as plain
files (config.toml, cuts.csv, posteriors/*.json, ...; docs/shopdb.md) so nothing is locked in."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.history import DbOpt

campaign_app = typer.Typer(help="Campaigns of a shop database: list, export to plain files, import.",
                           no_args_is_help=True, rich_markup_mode=None)
app.add_typer(campaign_app, name="campaign")


@campaign_app.command("list")
def list_cmd(db: str = DbOpt) -> None:
    """Every campaign: shop, machine, tool, updates and the last change."""
    from rich.console import Console
    from rich.table import Table

    from millstab.api import shop

    rows = shop.campaigns(db)
    table = Table(title=f"{len(rows)} campaign(s) in {db}")
    for col in ("campaign", "shop", "machine", "tool", "updates", "created", "last change"):
        table.add_column(col)
    for r in rows:
        table.add_row(r["name"], r["shop"], r["machine"] or "", r["tool"] or "", str(r["revision"]),
                      f"{r['created_at'][:10]} {r['created_by']}", r["updated_at"][:19].replace("T", " "))
    Console().print(table)


@campaign_app.command("export")
def export_cmd(
    db: str = DbOpt,
    campaign: str = typer.Option(..., "--campaign", help="The campaign to export."),
    out: Path = typer.Option(..., "--out", help="A new or empty folder for config.toml, cuts.csv, posteriors/, ..."),
) -> None:
    """Write a campaign as plain files (TOML, CSV, JSON) that millstab update/map/recommend read directly."""
    from millstab.api import shop

    folder = shop.export_campaign(db, campaign, out)
    typer.echo(f"wrote campaign {campaign} to {folder}")


@campaign_app.command("import")
def import_cmd(
    folder: Path = typer.Argument(..., help="A folder written by millstab campaign export."),
    db: str = DbOpt,
    name: Optional[str] = typer.Option(None, "--as", help="Import under this campaign name (default: its own)."),
    user: Optional[str] = typer.Option(None, "--user", help="Who imports (default: $USER)."),
    shop_name: Optional[str] = typer.Option(None, "--shop", help="The shop it belongs to in the app (default: its "
                                                                  "own, else 'default'); see docs/app.md."),
) -> None:
    """Create a campaign in a shop database from an exported folder (times and users as recorded)."""
    from millstab.api import shop

    got = shop.import_campaign(db, folder, name, user, shop_name)
    typer.echo(f"imported campaign {got} into {db}")


@campaign_app.command("check")
def check_cmd(db: str = DbOpt) -> None:
    """Check a shop database: SQLite's integrity and foreign keys, every campaign's current posterior and cuts."""
    from millstab.api import shop

    problems = shop.check(db)
    for p in problems:
        typer.echo(f"problem: {p}")
    typer.echo(f"{db}: {'consistent' if not problems else f'{len(problems)} problem(s)'}")
    if problems:
        raise typer.Exit(1)
