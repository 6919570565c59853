"""``millstab history``: what happened in a shop database (who recorded which cuts, updates,
recommendations, and when), newest first."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from millstab.cli.app import app
from millstab.errors import InputError

_DB_HELP = ("Shop database: a file (SQLite, created by an update) or a SQLAlchemy URL "
            "(postgresql+psycopg://user@host/shop); needs millstab[db]. See docs/shopdb.md.")
DbOpt = typer.Option(..., "--db", help=_DB_HELP)
# for the commands that also work from files (update, map, recommend, predict, listen): `db: ShopDbOpt = None`
ShopDbOpt = Annotated[Optional[str], typer.Option("--db", help=_DB_HELP)]
CampaignOpt = Annotated[Optional[str], typer.Option("--campaign", help="The campaign in --db (an update creates it).")]
UserOpt = Annotated[Optional[str], typer.Option("--user", help="Who does it, for the history (default: $USER).")]
ShopOpt = Annotated[Optional[str], typer.Option("--shop", help="The shop of a new campaign in --db: who may see it in "
                                                              "the app (default: 'default'); see docs/shopdb.md.")]


def shop_target(db: str | None, campaign: str | None) -> bool:
    """True when the command works on a campaign in a shop database (--db and --campaign given), False when
    on files (neither given).

    Raises:
        InputError: one given without the other.
    """
    if (db is None) != (campaign is None):
        missing, given = ("--campaign", db) if campaign is None else ("--db", campaign)
        raise InputError(missing, None, f"--db and --campaign go together (got {given!r} alone): "
                                        "--db shop.db --campaign NAME")
    return db is not None


def posterior_source(posterior, db: str | None, campaign: str | None, user: str | None = None):
    """``(posterior, inputs, posterior id)``: the posterior of a file POSTERIOR or of a campaign's current one
    (--db and --campaign), the input paths to protect from being overwritten, and its id in the database
    (``None`` for a file).

    Raises:
        InputError: neither or both given, --db without --campaign.
    """
    if shop_target(db, campaign):
        if posterior is not None:
            raise InputError("POSTERIOR", str(posterior), "give a posterior file or --db/--campaign, not both (with "
                                                          "--db the campaign's current posterior is used)")
        from millstab.api.shop import posterior_from_db

        pid, post = posterior_from_db(db, campaign, user)
        return post, {}, pid
    if posterior is None:
        raise InputError("POSTERIOR", None, "missing: a posterior JSON from millstab update, or --db shop.db "
                                            "--campaign NAME for a campaign's current posterior")
    from millstab.cli.update import _load_posterior

    return _load_posterior(posterior), {"POSTERIOR": posterior}, None


@app.command("history")
def history_cmd(
    db: str = DbOpt,
    campaign: Optional[str] = typer.Option(None, "--campaign", help="Only this campaign (default: all)."),
    limit: int = typer.Option(50, "--limit", help="Show the newest LIMIT events."),
    before: Optional[int] = typer.Option(None, "--before",
                                         help="Only events older than this event id (the next page)."),
    out: Optional[Path] = typer.Option(None, "--out",
                                       help="Also write the events as CSV id,at,user,campaign,action,detail."),
) -> None:
    """List what happened in a shop database, newest first: campaigns created, cuts, updates, recommendations."""
    from rich.console import Console
    from rich.table import Table

    from millstab.api import shop
    from millstab.io import check_outputs, write_csv

    check_outputs({}, {"--out": out})
    events = shop.history(db, campaign, limit, before)
    con = Console()
    table = Table(title=f"{campaign or 'all campaigns'}: {len(events)} newest event(s)" if events else None)
    for col in ("id", "at (UTC)", "user", "campaign", "action", "detail"):
        table.add_column(col, justify="right" if col == "id" else "left", overflow="fold")
    for e in events:
        table.add_row(str(e.id), e.at[:19].replace("T", " "), e.user, e.campaign or "", e.action, e.detail)
    if events:
        con.print(table)
    else:
        con.print("no events" + (f" before {before}" if before is not None else ""))
    if len(events) == limit and events[-1].id > 1:
        con.print(f"older events: --before {events[-1].id}")
    if out is not None:
        write_csv(out, *shop.history_table(events))
        con.print(f"wrote {out}")
