"""Shop memory: machines, tools, campaigns, cuts, posteriors and recommendations in a database.

A campaign (one tool on one machine) lives in a SQLite file (a plain path) or any SQLAlchemy database URL
(PostgreSQL for a shared server), with its whole history: who recorded which cut, which posterior came
from which data and code, which recommendation from which posterior. See docs/shopdb.md.

* :mod:`~millstab.shopdb.schema` -- the tables (SQLAlchemy Core) and the newest migration's id;
* ``migrations/`` -- the Alembic migrations, run on open (``upgrade head``);
* :mod:`~millstab.shopdb.store` -- :class:`Store`: one transaction per update, optimistic concurrency,
  reading a campaign back, the history;
* :mod:`~millstab.shopdb.files` -- a campaign as plain files (config.toml, cuts.csv, posteriors/, ...).

SQLAlchemy and Alembic are the optional extra ``millstab[db]``; this module imports them only when a
database is opened, so the rest of millstab works without them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from millstab.errors import InputError

INSTALL = "pip install 'millstab[db]' (SQLAlchemy and Alembic)"
#: the shop of a campaign made without naming one (the command line), and of an app account that names none
DEFAULT_SHOP = "default"


@dataclass(frozen=True)
class CutsBy:
    """Who and what recorded cuts, as the database keeps it (one object instead of five keywords of
    :meth:`~millstab.shopdb.store.Store.record_update` and :func:`millstab.api.shop.update_in_db`).

    Attributes:
        user: who records them (default: the store's user, ``$USER``).
        machine, tool: the campaign's machine and tool (set when the campaign is created, at its first write).
        raters: per new cut, who labelled it (``None``: nobody named).
        recordings: per new cut, a reference to its recording (``None``: none).
        source: where the new cuts came from (``millstab update --db`` gives the cuts file's absolute path), kept in
            the event that records them so that a cut can be traced to its file (``None``: not said).
    """

    user: str | None = None
    machine: str | None = None
    tool: str | None = None
    raters: Sequence[str] | None = None
    recordings: Sequence[str] | None = None
    source: str | None = None


def check_shop(name, field: str = "--shop") -> str:
    """A shop name: 1..64 letters, digits or ``_ . @ + -`` (the characters of the app's user names, so that a
    users file can name every shop a campaign can have)."""
    import re

    text = str(name).strip()
    if not re.fullmatch(r"[A-Za-z0-9_.@+-]{1,64}", text):
        raise InputError(field, name, "a shop name of 1..64 letters, digits or _ . @ + -")
    return text


def available() -> bool:
    """True when SQLAlchemy and Alembic are installed."""
    import importlib.util

    return all(importlib.util.find_spec(m) is not None for m in ("sqlalchemy", "alembic"))


def open_store(db, user: str | None = None, create: bool = True):
    """Open (and create or migrate) the shop database ``db``: a file path (SQLite) or a SQLAlchemy URL;
    ``user``: who acts (default $USER); ``create=False``: a SQLite file that does not exist is an error (the
    reading commands never leave an empty database behind). Returns a :class:`millstab.shopdb.store.Store`.

    Raises:
        InputError: the extra is not installed, or the database cannot be opened (one line naming --db).
    """
    if not available():
        raise InputError("--db", str(db), f"the shop database needs SQLAlchemy and Alembic: {INSTALL}")
    from millstab.shopdb.store import Store

    return Store(str(db), user, create)


__all__ = ["DEFAULT_SHOP", "INSTALL", "CutsBy", "check_shop", "available", "open_store"]
