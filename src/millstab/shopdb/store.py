"""The shop database: open it, record updates in one transaction, read a campaign back, list its history.

Rules (docs/shopdb.md):

* **One update, one transaction.** :meth:`Store.record_update` inserts the config (once per text), the
  posterior, its new cut rows and an event, and moves the campaign's head to the new posterior, all in one
  transaction. A process killed before the commit leaves nothing of it: the previous posterior stays current.
* **Optimistic concurrency.** An update reads the head (posterior id and row count), computes for seconds
  without holding a lock, then records *only if the head is still the one it started from*; otherwise it
  raises :class:`StaleError` naming who landed first and when. The check and the write are one write
  transaction (SQLite: ``BEGIN IMMEDIATE``, which serialises writers; other databases: the campaign row is
  locked with ``SELECT ... FOR UPDATE``), so two updates can never both land on the same head.
* **SQLite** (a plain path): WAL journal (readers never wait for the writer), foreign keys on, a 30 s busy
  timeout, ``synchronous = FULL`` (a commit survives a power cut). Any other SQLAlchemy URL
  (``postgresql+psycopg://…``) works the same way.
* **Errors are one line.** A read-only database, a full disk, a missing folder, a file that is not a shop
  database, a database from a newer millstab: each an :class:`InputError` naming ``--db``.

Only this package imports SQLAlchemy; :func:`millstab.shopdb.open_store` imports it lazily.
"""

from __future__ import annotations

import difflib
import functools
import getpass
import hashlib
import json
import math
import os
import re
import subprocess
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np
import sqlalchemy as sa
from sqlalchemy import event as sa_event
from sqlalchemy import exc as sa_exc

from millstab.errors import InputError
from millstab.io.results import to_jsonable
from millstab.io.stickout import COLUMN as STICKOUT
from millstab.points import CONDITION_COLUMNS, PointSet
from millstab.shopdb import CutsBy, check_shop
from millstab.shopdb import schema as T

#: how long a writer waits for another writer's lock before giving up [s]
BUSY_TIMEOUT_S = 30.0
#: the most rows :meth:`Store.history` returns at once (page with ``before=``)
MAX_HISTORY = 10_000
_NAME_RULE = "1-200 characters, no control characters (e.g. 't12-m1')"


class StaleError(InputError):
    """The campaign moved on while an update computed: another update landed first."""


def now() -> str:
    """The current UTC time as the database stores it (ISO 8601, microseconds, 'Z')."""
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def default_user(user: str | None = None) -> str:
    """``user`` if given, else $USER (the login name), else ``"unknown"``; checked like a name."""
    if user is None:
        try:
            user = os.environ.get("USER") or getpass.getuser()
        except Exception:  # no login name in some containers
            user = "unknown"
    return _check_name(user, "--user", 100)


def _check_name(name: str, field: str, most: int = 200) -> str:
    text = str(name).strip()
    if not 0 < len(text) <= most or re.search(r"[\x00-\x1f\x7f]", text):
        raise InputError(field, name, _NAME_RULE.replace("200", str(most)))
    return text


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """millstab's version, with the git commit of its source tree when it runs from a checkout
    (``0.1.0+g1a2b3c4d5e6f``): the code a posterior came from."""
    import millstab

    version = millstab.__version__
    try:
        done = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=Path(millstab.__file__).parent,
                              capture_output=True, text=True, timeout=5)
        if done.returncode == 0 and re.fullmatch(r"[0-9a-f]{7,40}", done.stdout.strip()):
            version += "+g" + done.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return version


def data_hash(config_toml: str, cuts: PointSet) -> str:
    """sha256 of the config text and the cut rows (exact floats): the data a posterior came from."""
    h = hashlib.sha256(config_toml.encode("utf-8"))
    own = cut_settings(cuts)
    for i, (r, d, lab, w, hz, g) in enumerate(zip(cuts.rpm, cuts.depth_mm, cuts.label, cuts.weight, cuts.chatter_hz,
                                                 cuts.grade)):
        h.update(f"\n{float(r)!r},{float(d)!r},{lab},{float(w)!r},{float(hz)!r},{float(g)!r}".encode())
        if own[i]:  # a cut's own condition or stickout (cuts in the config's hash as before migration 0003)
            h.update(json.dumps(own[i], sort_keys=True).encode())
    return h.hexdigest()


#: the cut table's columns of a cut's own condition and stickout (migration 0003): NULL = the config's value
SETTINGS = CONDITION_COLUMNS + (STICKOUT,)


def cut_settings(cuts: PointSet) -> list[dict]:
    """Per cut, its own condition and stickout as cut-table values: ``{column: value}`` of its non-empty
    condition cells (:data:`millstab.points.CONDITION_COLUMNS`) and ``stickout_mm`` cell (mm as written);
    ``{}`` for a cut in the config's condition and stickout.

    Raises:
        InputError: a stickout cell that is not a number of mm (:func:`millstab.io.stickout.stickouts_mm`).
    """
    from millstab.io.stickout import stickouts_mm

    cols = dict(cuts.conditions)
    so = stickouts_mm(cuts)
    if so is not None:
        cols[STICKOUT] = so
    out: list[dict] = [{} for _ in range(len(cuts))]
    for name, col in cols.items():
        for i, v in enumerate(col):
            if name == "milling":
                if v:
                    out[i][name] = str(v)
            elif not math.isnan(v):
                out[i][name] = int(v) if name == "teeth" else float(v)
    return out


def _float_or_none(x: float) -> float | None:
    x = float(x)
    return None if math.isnan(x) else x


def _nan(x) -> float:
    return math.nan if x is None else float(x)


def json_text(doc) -> str:
    """A result document as the JSON text stored in the database (the same floats as ``write_json``)."""
    return json.dumps(to_jsonable(doc), ensure_ascii=False, allow_nan=False, separators=(",", ":"))


@dataclass(frozen=True)
class Head:
    """Where a campaign stands: its current posterior and how many cut rows it holds."""

    campaign_id: int
    name: str
    revision: int
    posterior_id: int | None
    n_rows: int
    config_sha256: str | None
    engine: str | None
    updated_at: str
    updated_by: str | None


@dataclass(frozen=True)
class Snapshot:
    """A campaign as one read transaction saw it (:meth:`Store.snapshot`)."""

    head: Head
    rows: list[dict]
    posterior_doc: dict | None
    config_toml: str | None = None  # the config text of the current posterior (None before the first update)

    @property
    def cuts(self) -> PointSet:
        return cuts_from_rows(self.rows)

    def posterior(self):
        """The current :class:`~millstab.update.Posterior` (``None`` before the first update)."""
        from millstab.update.posterior import Posterior

        if self.posterior_doc is None:
            return None
        return Posterior.from_json(self.posterior_doc, f"{self.head.name} posterior {self.head.posterior_id}")


@dataclass(frozen=True)
class Event:
    """One line of a campaign's history."""

    id: int
    at: str
    user: str
    campaign: str | None
    action: str
    detail: str
    posterior_id: int | None = None
    recommendation_id: int | None = None


def _sqlite_target(db: str) -> tuple[str, Path | None]:
    """(SQLAlchemy URL, file path or None) of ``--db``: a URL as given, a plain path as SQLite."""
    if "://" in db:
        return db, None
    p = Path(db).expanduser()
    if p.is_dir():
        raise InputError("--db", db, "a folder; give a database file, e.g. shop.db, or a database URL")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError("--db", db, f"the folder {str(parent)!r} does not exist; create it or choose another path")
    return "sqlite:///" + str(p.resolve()), p


class Store:
    """An open shop database (:func:`millstab.shopdb.open_store`)."""

    def __init__(self, db: str, user: str | None = None, create: bool = True):
        self.url = str(db)
        self.user = default_user(user)
        url, self.path = _sqlite_target(self.url)
        try:
            u = sa.engine.make_url(url)
        except sa_exc.ArgumentError:
            raise InputError("--db", self.url, "a database file path, or a SQLAlchemy URL such as "
                                               "postgresql+psycopg://user@host/shop") from None
        self.sqlite = u.get_backend_name() == "sqlite"
        if self.sqlite and self.path is None:
            if not u.database or u.database == ":memory:":
                raise InputError("--db", self.url, "an in-memory SQLite database forgets everything; give a file")
            # sqlite:///file:PATH?mode=ro&uri=true is an SQLite URI: its file is PATH
            self.path = Path(u.database[5:] if u.database.startswith("file:") else u.database)
        try:
            kw = {"connect_args": {"timeout": BUSY_TIMEOUT_S}} if self.sqlite else {"pool_pre_ping": True}
            self.engine = sa.create_engine(u, **kw)
        except ImportError as exc:  # a driver that is not installed (psycopg, ...)
            raise InputError("--db", self.url, f"its database driver is not installed ({exc}); "
                                               "pip install it, e.g. psycopg[binary] for PostgreSQL") from None
        except sa_exc.ArgumentError as exc:  # postgres:// (not postgresql://), an unknown dialect
            raise InputError("--db", self.url, f"not a database URL SQLAlchemy knows ({exc}); e.g. "
                                               "postgresql+psycopg://user@host/shop, or a file path") from None
        if not create and self.path is not None and not self.path.exists():
            raise InputError("--db", self.url, "no such database file (an update with --db creates one)")
        if create and self.sqlite and self.path is not None and not u.database.startswith("file:"):
            _create_private(self.path)
        if self.sqlite:
            sa_event.listen(self.engine, "connect", _sqlite_connect)
            sa_event.listen(self.engine, "begin", _sqlite_begin)
        migrate(self)

    # -- plumbing -------------------------------------------------------------------------------------------

    def close(self) -> None:
        """Close every pooled connection."""
        self.engine.dispose()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Store({self.url!r})"

    @contextmanager
    def transaction(self, write: bool = False) -> Iterator[sa.Connection]:
        """A connection in one transaction (committed at the end, rolled back on an error); ``write``: a
        writer's transaction (SQLite: ``BEGIN IMMEDIATE``, which takes the write lock at once)."""
        with self.errors("write to" if write else "read"):
            with self.engine.connect() as conn:
                conn.execution_options(shopdb_write=write)
                with conn.begin():
                    yield conn

    @contextmanager
    def errors(self, doing: str = "use") -> Iterator[None]:
        """Database errors as one-line :class:`InputError` naming ``--db``."""
        try:
            yield
        except sa_exc.DBAPIError as exc:
            raise _translate(self.url, doing, exc) from None

    # -- campaigns ------------------------------------------------------------------------------------------

    def campaigns(self, shops: Sequence[str] | None = None) -> list[dict]:
        """Every campaign (of ``shops`` only, when given): name, shop, machine, tool, revision, created/updated
        time and user."""
        c, m, t = T.campaign, T.machine, T.tool
        q = (sa.select(c.c.name, c.c.shop, m.c.name.label("machine"), t.c.name.label("tool"), c.c.revision,
                       c.c.created_at, c.c.created_by, c.c.updated_at)
             .select_from(c.outerjoin(m, c.c.machine_id == m.c.id).outerjoin(t, c.c.tool_id == t.c.id))
             .order_by(c.c.name))
        if shops is not None:
            q = q.where(c.c.shop.in_(list(shops)))
        with self.transaction() as conn:
            return [dict(r._mapping) for r in conn.execute(q)]

    def campaign_shop(self, name: str) -> str | None:
        """The shop campaign ``name`` belongs to, or ``None`` when there is no such campaign (a campaign's shop
        never changes: it is set when the campaign is created)."""
        with self.transaction() as conn:
            return conn.execute(sa.select(T.campaign.c.shop).where(T.campaign.c.name == name)).scalar()

    def unknown(self, name: str, shops: Sequence[str] | None = None) -> InputError:
        """The error for a campaign that does not exist, or is not of ``shops``: the same words either way, so
        that a user cannot tell another shop's campaign from none."""
        with self.transaction() as conn:
            return self._unknown(conn, name, shops)

    def head(self, name: str, conn: sa.Connection | None = None, *, lock: bool = False) -> Head | None:
        """Where campaign ``name`` stands, or ``None`` when there is no such campaign."""
        if conn is None:
            with self.transaction() as conn:
                return self.head(name, conn)
        c, p, cf = T.campaign, T.posterior, T.config
        q = sa.select(c.c.id, c.c.revision, c.c.head_posterior_id, c.c.updated_at).where(c.c.name == name)
        if lock:
            q = q.with_for_update()
        row = conn.execute(q).first()
        if row is None:
            return None
        n_rows = conn.execute(sa.select(sa.func.count()).select_from(T.cut)
                              .where(T.cut.c.campaign_id == row.id)).scalar_one()
        sha = engine = by = None
        if row.head_posterior_id is not None:
            prow = conn.execute(sa.select(cf.c.sha256, p.c.engine, p.c.created_by)
                                .select_from(p.join(cf, p.c.config_id == cf.c.id))
                                .where(p.c.id == row.head_posterior_id)).first()
            sha, engine, by = prow
        return Head(row.id, name, row.revision, row.head_posterior_id, int(n_rows), sha, engine, row.updated_at, by)

    def _campaign_id(self, conn: sa.Connection, name: str) -> int:
        cid = conn.execute(sa.select(T.campaign.c.id).where(T.campaign.c.name == name)).scalar()
        if cid is None:
            raise self._unknown(conn, name)
        return cid

    def _unknown(self, conn: sa.Connection, name: str, shops: Sequence[str] | None = None) -> InputError:
        q = sa.select(T.campaign.c.name)
        names = list(conn.execute(q if shops is None else q.where(T.campaign.c.shop.in_(list(shops)))).scalars())
        low = {n.lower(): n for n in names}  # 'T12-M1 ' finds 't12-m1'
        close = [low[x] for x in difflib.get_close_matches(str(name).strip().lower(), list(low), n=3)]
        hint = f"; did you mean {', '.join(map(repr, close))}?" if close else ""
        some = f"it holds {len(names)} campaign(s)" + (f": {', '.join(names[:8])}" if 0 < len(names) <= 8 else "")
        return InputError("--campaign", name, f"no such campaign in {self.url} ({some}){hint}; "
                                              "`millstab history --db DB` lists them, and an update creates one")

    def _named(self, conn: sa.Connection, table: sa.Table, name: str | None, user: str, at: str) -> int | None:
        """The id of machine/tool ``name``, created when new."""
        if name is None:
            return None
        name = _check_name(name, f"--{table.name}")
        rid = conn.execute(sa.select(table.c.id).where(table.c.name == name)).scalar()
        if rid is None:
            rid = conn.execute(table.insert().values(name=name, note="", created_at=at,
                                                     created_by=user)).inserted_primary_key[0]
        return rid

    def _ensure_campaign(self, conn: sa.Connection, name: str, machine: str | None, tool: str | None, user: str,
                         at: str, shop: str | None = None) -> int:
        """The campaign's id, creating it (and its machine and tool) when new, in ``shop`` (default
        :data:`~millstab.shopdb.schema.DEFAULT_SHOP`); a machine or tool given for an existing campaign must be
        the one it has, and a ``shop`` given must be its shop (checked in the writer's transaction: the
        app's per-shop rule holds even against a campaign of the same name created a moment before)."""
        name = _check_name(name, "--campaign")
        c = T.campaign
        row = conn.execute(sa.select(c.c.id, c.c.machine_id, c.c.tool_id, c.c.shop).where(c.c.name == name)).first()
        if row is not None and shop is not None and row.shop != shop:
            raise InputError("--campaign", name,
                             "the name is taken by a campaign you cannot see; choose another name")  # = api.shop.TAKEN
        mid = self._named(conn, T.machine, machine, user, at)
        tid = self._named(conn, T.tool, tool, user, at)
        if row is None:
            cid = conn.execute(c.insert().values(name=name, machine_id=mid, tool_id=tid, note="", created_at=at,
                                                 created_by=user, updated_at=at, revision=0,
                                                 shop=check_shop(shop or T.DEFAULT_SHOP))
                               ).inserted_primary_key[0]
            what = ", ".join(f"{k} {v}" for k, v in (("shop", shop), ("machine", machine), ("tool", tool)) if v)
            self._event(conn, cid, user, at, "create", f"campaign {name}" + (f" ({what})" if what else ""))
            return cid
        for field, given, have, value in (("--machine", mid, row.machine_id, machine),
                                          ("--tool", tid, row.tool_id, tool)):
            if given is not None and have is not None and given != have:
                raise InputError(field, value, f"campaign {name!r} belongs to another {field[2:]}; "
                                               "start a new campaign for a new machine or tool")
        if (mid is not None and row.machine_id is None) or (tid is not None and row.tool_id is None):
            conn.execute(c.update().where(c.c.id == row.id).values(machine_id=row.machine_id or mid,
                                                                   tool_id=row.tool_id or tid))
        return row.id

    @staticmethod
    def _event(conn: sa.Connection, cid: int | None, user: str, at: str, action: str, detail: str,
               posterior_id: int | None = None, recommendation_id: int | None = None) -> int:
        return conn.execute(T.event.insert().values(campaign_id=cid, at=at, user=user, action=action, detail=detail,
                                                    posterior_id=posterior_id,
                                                    recommendation_id=recommendation_id)).inserted_primary_key[0]

    # -- writing --------------------------------------------------------------------------------------------

    def _config_id(self, conn: sa.Connection, cid: int, toml: str, user: str, at: str) -> int:
        sha = hashlib.sha256(toml.encode("utf-8")).hexdigest()
        row = conn.execute(sa.select(T.config.c.id).where(T.config.c.campaign_id == cid,
                                                          T.config.c.sha256 == sha)).scalar()
        if row is None:
            row = conn.execute(T.config.insert().values(campaign_id=cid, sha256=sha, toml=toml, created_at=at,
                                                        created_by=user)).inserted_primary_key[0]
        return row

    @staticmethod
    def _cut_rows(cid: int, first_seq: int, cuts: PointSet, raters: Sequence[str] | None,
                  recordings: Sequence[str] | None, posterior_id: int | None, user: str, at: str) -> list[dict]:
        n = len(cuts)
        heard = (cuts.extra or {}).get("recording")  # cuts labelled by listening (update's `recording` column)
        if heard is not None:  # their provenance, as `listen --db` records it: the recording and the rater listen
            recordings = [str(x) for x in heard] if recordings is None else recordings
            raters = ["listen" if str(x) else "" for x in heard] if raters is None else raters
        for field, seq in (("raters", raters), ("recordings", recordings)):
            if seq is not None and len(seq) != n:
                raise InputError(field, f"{len(seq)} values", f"need one per cut ({n})")
        own = cut_settings(cuts)
        return [{"campaign_id": cid, "seq": first_seq + i, "rpm": float(cuts.rpm[i]),
                 "depth_mm": float(cuts.depth_mm[i]),
                 "label": str(cuts.label[i]), "grade": _float_or_none(cuts.grade[i]), "weight": float(cuts.weight[i]),
                 "chatter_hz": _float_or_none(cuts.chatter_hz[i]), "batch": str(cuts.batch[i]),
                 "rater": str(raters[i]) if raters is not None else "",
                 "recording": str(recordings[i]) if recordings is not None else "",
                 "posterior_id": posterior_id, "created_at": at, "created_by": user,
                 **{k: own[i].get(k) for k in SETTINGS}} for i in range(n)]

    def _check_head(self, conn: sa.Connection, name: str, expected_head: int | None, expected_rows: int) -> Head | None:
        """The campaign's head, locked; :class:`StaleError` when it is not the one the caller started from."""
        head = self.head(name, conn, lock=True)
        have = (head.posterior_id, head.n_rows) if head is not None else (None, 0)
        if have != (expected_head, expected_rows):
            by = f"by {head.updated_by or 'someone'} at {head.updated_at}" if head is not None else ""
            raise StaleError("--campaign", name,
                             f"stale: another update ({by}) landed first: the campaign now holds {have[1]} cut rows "
                             f"and posterior {have[0]}, this update started from {expected_rows} rows and posterior "
                             f"{expected_head}; nothing was recorded; re-run to start from it")
        return head

    def record_update(self, name: str, config_toml: str, new_cuts: PointSet, posterior, *,
                      expected_head: int | None, expected_rows: int, parent: int | None = None, seed: int | None = None,
                      by: CutsBy | None = None, all_cuts: PointSet | None = None, note: str = "",
                      shop: str | None = None) -> int:
        """Record one update in one transaction and make its posterior current; returns the posterior's id.

        Args:
            name: the campaign (created, with its machine and tool, at its first update).
            config_toml: the config text the update used (its prior).
            new_cuts: the cut rows this update adds (after the ``expected_rows`` already stored).
            posterior: the :class:`~millstab.update.Posterior` of all the campaign's rows (or its JSON dict).
            expected_head, expected_rows: the head posterior id (``None`` for none yet) and the number of cut
                rows the update read when it started (optimistic concurrency).
            parent: the posterior the sampler started from (``start=``), ``None`` for a fresh update.
            by: who records it and the new cuts' machine, tool, raters and recordings (:class:`CutsBy`; default:
                the store's user, nothing else named).
            all_cuts: every row the posterior used (for its data hash); default: not hashed with the old rows.
            shop: the shop of a new campaign; for an existing one, its shop (anything else is refused).
        Raises:
            StaleError: the campaign's head or cut count is no longer the expected one (nothing recorded).
            InputError: a bad name, a database error (read-only, full disk, ...).
        """
        by = by or CutsBy()
        user = default_user(by.user) if by.user is not None else self.user
        doc = posterior if isinstance(posterior, dict) else posterior.to_json()
        text = json_text(doc)
        n_samples = len(doc.get("samples") or ())
        at = now()
        with self.transaction(write=True) as conn:
            self._check_head(conn, name, expected_head, expected_rows)
            cid = self._ensure_campaign(conn, name, by.machine, by.tool, user, at, shop)
            cfg_id = self._config_id(conn, cid, config_toml, user, at)
            pid = conn.execute(T.posterior.insert().values(
                campaign_id=cid, parent_id=parent, config_id=cfg_id, n_rows=expected_rows + len(new_cuts),
                engine=str(doc.get("engine", "zoa")), samples=n_samples, seed=seed, code_version=code_version(),
                data_hash=data_hash(config_toml, all_cuts if all_cuts is not None else new_cuts), doc=text,
                created_at=at, created_by=user)).inserted_primary_key[0]
            rows = self._cut_rows(cid, expected_rows, new_cuts, by.raters, by.recordings, pid, user, at)
            if rows:
                conn.execute(T.cut.insert(), rows)
            conn.execute(T.campaign.update().where(T.campaign.c.id == cid)
                         .values(head_posterior_id=pid, revision=T.campaign.c.revision + 1, updated_at=at))
            start = f"from posterior {parent}" if parent is not None else "from the prior"
            src = f" from {by.source}" if by.source and len(new_cuts) else ""  # the file, to trace a cut to it
            detail = (f"update: +{len(new_cuts)} cut(s){src}, {expected_rows + len(new_cuts)} in all; "
                      f"{n_samples} samples, {doc.get('engine', 'zoa')}, seed {seed}, {start}"
                      + (f"; {note}" if note else ""))
            self._event(conn, cid, user, at, "update", detail, posterior_id=pid)  # the last write before the commit
        return pid

    def add_cuts(self, name: str, cuts: PointSet, *, expected_rows: int | None = None, machine: str | None = None,
                 tool: str | None = None, user: str | None = None, raters: Sequence[str] | None = None,
                 recordings: Sequence[str] | None = None, shop: str | None = None) -> int:
        """Record cuts without an update (an operator's day at the machine); the next update uses them.
        Returns the campaign's number of cut rows. ``expected_rows``: refuse (:class:`StaleError`) when
        the campaign does not hold that many rows (someone else added cuts meanwhile); ``shop``: as in
        :meth:`record_update`."""
        user = default_user(user) if user is not None else self.user
        at = now()
        with self.transaction(write=True) as conn:
            head = self.head(name, conn, lock=True)
            n = head.n_rows if head is not None else 0
            if expected_rows is not None and n != expected_rows:
                raise StaleError("--campaign", name, f"stale: it now holds {n} cut rows, not {expected_rows} "
                                                     "(someone added cuts meanwhile); nothing was recorded; re-run")
            cid = self._ensure_campaign(conn, name, machine, tool, user, at, shop)
            rows = self._cut_rows(cid, n, cuts, raters, recordings, None, user, at)
            if rows:
                conn.execute(T.cut.insert(), rows)
            conn.execute(T.campaign.update().where(T.campaign.c.id == cid).values(updated_at=at))
            self._event(conn, cid, user, at, "cuts", f"cuts: +{len(cuts)} recorded, {n + len(cuts)} in all")
        return n + len(cuts)

    def record_recommendation(self, name: str, doc: dict, posterior_id: int, user: str | None = None) -> int:
        """Record a recommendation (its JSON) made from posterior ``posterior_id``; returns its id."""
        user = default_user(user) if user is not None else self.user
        at = now()
        with self.transaction(write=True) as conn:
            cid = self._campaign_id(conn, name)
            rid = conn.execute(T.recommendation.insert().values(campaign_id=cid, posterior_id=posterior_id,
                                                                doc=json_text(doc), created_at=at,
                                                                created_by=user)).inserted_primary_key[0]
            nt = doc.get("next_test") or {}
            detail = (f"recommend: {doc.get('rpm', math.nan):.0f} rpm, {doc.get('depth_mm', math.nan):.3f} mm at risk "
                      f"{doc.get('risk', '?')} from posterior {posterior_id}")
            if nt:
                detail += f"; next test {nt.get('rpm', math.nan):.0f} rpm, {nt.get('depth_mm', math.nan):.3f} mm"
            self._event(conn, cid, user, at, "recommend", detail, posterior_id=posterior_id, recommendation_id=rid)
        return rid

    # -- reading --------------------------------------------------------------------------------------------

    def snapshot(self, name: str, with_posterior: bool = True) -> Snapshot | None:
        """Opening a campaign: its head, every cut row and the current posterior's JSON, read in one
        transaction (one consistent state even while another process writes); ``None`` for no such campaign."""
        with self.transaction() as conn:
            head = self.head(name, conn)
            if head is None:
                return None
            q = sa.select(*[col for col in T.cut.c if col.name not in ("id", "campaign_id")])
            rows = [dict(r._mapping) for r in conn.execute(q.where(T.cut.c.campaign_id == head.campaign_id)
                                                           .order_by(T.cut.c.seq))]
            doc = toml = None
            if with_posterior and head.posterior_id is not None:
                p, cf = T.posterior, T.config
                text, toml = conn.execute(sa.select(p.c.doc,
                                                    cf.c.toml).select_from(p.join(cf, p.c.config_id == cf.c.id))
                                          .where(p.c.id == head.posterior_id)).one()
                doc = json.loads(text)
        return Snapshot(head, rows, doc, toml)

    def latest_posterior_doc(self, name: str) -> tuple[int, dict]:
        """(id, JSON document) of the campaign's current posterior.

        Raises:
            InputError: no such campaign, or no update yet.
        """
        with self.transaction() as conn:
            row = conn.execute(sa.select(T.campaign.c.head_posterior_id).where(T.campaign.c.name == name)).first()
            if row is None:
                raise self._unknown(conn, name)
            if row.head_posterior_id is None:
                raise InputError("--campaign", name, "has cuts but no posterior yet; run millstab update --db first")
            text = conn.execute(sa.select(T.posterior.c.doc)
                                .where(T.posterior.c.id == row.head_posterior_id)).scalar_one()
        return row.head_posterior_id, json.loads(text)

    def latest_posterior(self, name: str):
        """The campaign's current :class:`~millstab.update.Posterior`."""
        from millstab.update.posterior import Posterior

        pid, doc = self.latest_posterior_doc(name)
        return Posterior.from_json(doc, f"{name} posterior {pid}")

    def posterior_doc(self, posterior_id: int) -> dict:
        """The JSON document of one posterior by id."""
        with self.transaction() as conn:
            text = conn.execute(sa.select(T.posterior.c.doc).where(T.posterior.c.id == posterior_id)).scalar()
        if text is None:
            raise InputError("posterior id", posterior_id, "no such posterior in this database")
        return json.loads(text)

    def cut_rows(self, name: str) -> list[dict]:
        """Every cut row of a campaign in order, with its rater, recording, batch, grade and who added it."""
        snap = self.snapshot(name, with_posterior=False)
        if snap is None:
            with self.transaction() as conn:
                raise self._unknown(conn, name)
        return snap.rows

    def cuts(self, name: str) -> PointSet:
        """The campaign's cuts (every round, in order) as a :class:`PointSet`."""
        return cuts_from_rows(self.cut_rows(name))

    def history(self, campaign: str | None = None, limit: int = 50, before: int | None = None,
                shops: Sequence[str] | None = None) -> list[Event]:
        """The newest ``limit`` events (newest first), of one campaign or of all (of ``shops``' campaigns
        only, when given); ``before``: only events with a smaller id (the next page)."""
        if not 1 <= int(limit) <= MAX_HISTORY:
            raise InputError("--limit", limit, f"between 1 and {MAX_HISTORY}")
        e, c = T.event, T.campaign
        q = sa.select(e.c.id, e.c.at, e.c.user, c.c.name, e.c.action, e.c.detail, e.c.posterior_id,
                      e.c.recommendation_id).select_from(e.outerjoin(c, e.c.campaign_id == c.c.id))
        with self.transaction() as conn:
            if campaign is not None:
                q = q.where(e.c.campaign_id == self._campaign_id(conn, campaign))
            if shops is not None:
                q = q.where(c.c.shop.in_(list(shops)))
            if before is not None:
                q = q.where(e.c.id < int(before))
            rows = conn.execute(q.order_by(e.c.id.desc()).limit(int(limit))).all()
        return [Event(*r) for r in rows]

    # -- a campaign as one plain structure (export / import: millstab.shopdb.files) --------------------------

    def export_bundle(self, name: str) -> dict:
        """Everything of one campaign as plain data, ids replaced by positions (see :func:`import_bundle`)."""
        c, p, cf, r, e = T.campaign, T.posterior, T.config, T.recommendation, T.event
        with self.transaction() as conn:
            cid = self._campaign_id(conn, name)
            camp = conn.execute(sa.select(c).where(c.c.id == cid)).first()._mapping
            machine = conn.execute(sa.select(T.machine.c.name).where(T.machine.c.id == camp["machine_id"])).scalar()
            tool = conn.execute(sa.select(T.tool.c.name).where(T.tool.c.id == camp["tool_id"])).scalar()
            configs = [dict(x._mapping)
                       for x in conn.execute(sa.select(cf).where(cf.c.campaign_id == cid).order_by(cf.c.id))]
            posts = [dict(x._mapping)
                     for x in conn.execute(sa.select(p).where(p.c.campaign_id == cid).order_by(p.c.id))]
            recs = [dict(x._mapping) for x in conn.execute(sa.select(r).where(r.c.campaign_id == cid).order_by(r.c.id))]
            events = [dict(x._mapping)
                      for x in conn.execute(sa.select(e).where(e.c.campaign_id == cid).order_by(e.c.id))]
            q = sa.select(*[col for col in T.cut.c if col.name not in ("id", "campaign_id")])
            cuts = [dict(x._mapping) for x in conn.execute(q.where(T.cut.c.campaign_id == cid).order_by(T.cut.c.seq))]
        ci = {x["id"]: i for i, x in enumerate(configs)}
        pi = {x["id"]: i for i, x in enumerate(posts)}
        ri = {x["id"]: i for i, x in enumerate(recs)}
        who = ("created_at", "created_by")
        for x in cuts:
            x["posterior"] = pi.get(x.pop("posterior_id"))
        return {
            "name": camp["name"], "shop": camp["shop"], "machine": machine, "tool": tool, "note": camp["note"],
            "created_at": camp["created_at"], "created_by": camp["created_by"], "updated_at": camp["updated_at"],
            "revision": camp["revision"], "head": pi.get(camp["head_posterior_id"]),
            "configs": [{"toml": x["toml"], **{k: x[k] for k in ("sha256",) + who}} for x in configs],
            "posteriors": [{"doc": json.loads(x["doc"]), "parent": pi.get(x["parent_id"]), "config": ci[x["config_id"]],
                            **{k: x[k]
                               for k in ("n_rows", "engine", "samples", "seed", "code_version", "data_hash") + who}}
                           for x in posts],
            "recommendations": [{"doc": json.loads(x["doc"]), "posterior": pi[x["posterior_id"]],
                                 **{k: x[k] for k in who}}
                                for x in recs],
            "cuts": cuts,
            "events": [{"at": x["at"], "user": x["user"], "action": x["action"], "detail": x["detail"],
                        "posterior": pi.get(x["posterior_id"]), "recommendation": ri.get(x["recommendation_id"])}
                       for x in events],
        }

    def import_bundle(self, bundle: dict, name: str | None = None, user: str | None = None) -> str:
        """Create a campaign from :meth:`export_bundle` data (times and users as recorded), in one
        transaction, and log an ``import`` event; returns its name.

        Raises:
            InputError: the campaign exists already (import it under another ``name``), or a reference
                in the bundle points nowhere.
        """
        user = default_user(user) if user is not None else self.user
        name = _check_name(name or bundle["name"], "--as")
        at = now()
        with self.transaction(write=True) as conn:
            if conn.execute(sa.select(T.campaign.c.id).where(T.campaign.c.name == name)).first() is not None:
                raise InputError("--as", name, f"campaign {name!r} exists in {self.url}; import under another name")
            mid = self._named(conn, T.machine, bundle.get("machine"), user, at)
            tid = self._named(conn, T.tool, bundle.get("tool"), user, at)
            cid = conn.execute(T.campaign.insert().values(
                name=name, machine_id=mid, tool_id=tid, note=bundle.get("note", ""),
                shop=check_shop(bundle.get("shop") or T.DEFAULT_SHOP), created_at=bundle["created_at"],
                created_by=bundle["created_by"], updated_at=bundle["updated_at"],
                revision=int(bundle["revision"]))).inserted_primary_key[0]
            cfg_ids = [conn.execute(T.config.insert().values(campaign_id=cid, toml=x["toml"],
                                                             sha256=hashlib.sha256(x["toml"].encode()).hexdigest(),
                                                             created_at=x["created_at"], created_by=x["created_by"])
                                    ).inserted_primary_key[0] for x in bundle["configs"]]
            pids: list[int] = []

            def ref(ids: list[int], i, what: str):
                if i is None:
                    return None
                if not (isinstance(i, int) and 0 <= i < len(ids)):
                    raise InputError(what, i, f"refers to no {what.split()[0]} of the campaign (0..{len(ids) - 1})")
                return ids[i]

            for x in bundle["posteriors"]:
                pids.append(conn.execute(T.posterior.insert().values(
                    campaign_id=cid, parent_id=ref(pids, x["parent"], "posterior parent"),
                    config_id=ref(cfg_ids, x["config"], "config of a posterior"), doc=json_text(x["doc"]),
                    **{k: x[k] for k in ("n_rows", "engine", "samples", "seed", "code_version", "data_hash",
                                         "created_at", "created_by")})).inserted_primary_key[0])
            if bundle["cuts"]:
                conn.execute(T.cut.insert(), [{**{k: v for k, v in x.items() if k != "posterior"}, "campaign_id": cid,
                                               "posterior_id": ref(pids, x["posterior"], "posterior of a cut")}
                                              for x in bundle["cuts"]])
            rids = [conn.execute(T.recommendation.insert().values(
                campaign_id=cid, posterior_id=ref(pids, x["posterior"], "posterior of a recommendation"),
                doc=json_text(x["doc"]), created_at=x["created_at"],
                created_by=x["created_by"])).inserted_primary_key[0]
                for x in bundle["recommendations"]]
            for x in bundle["events"]:
                self._event(conn, cid, x["user"], x["at"], x["action"], x["detail"],
                            ref(pids, x.get("posterior"), "posterior of an event"),
                            ref(rids, x.get("recommendation"), "recommendation of an event"))
            conn.execute(T.campaign.update().where(T.campaign.c.id == cid)
                         .values(head_posterior_id=ref(pids, bundle.get("head"), "head posterior")))
            self._event(conn, cid, user, at, "import", f"import: campaign {bundle['name']} as {name} "
                                                       f"({len(bundle['cuts'])} cut rows, {len(pids)} posteriors)")
        return name

    def check(self) -> list[str]:
        """Problems found (empty when consistent): SQLite's integrity and foreign-key checks, and every
        campaign's head being its own newest posterior, over no more rows than the campaign holds."""
        problems = []
        with self.transaction() as conn:
            if self.sqlite:
                ok = [r[0] for r in conn.exec_driver_sql("PRAGMA integrity_check")]
                if ok != ["ok"]:
                    problems += [f"integrity: {x}" for x in ok]
                problems += [f"foreign key: {tuple(r)}" for r in conn.exec_driver_sql("PRAGMA foreign_key_check")]
            c, p = T.campaign, T.posterior
            newest = (sa.select(p.c.campaign_id, sa.func.max(p.c.id).label("pid")).group_by(p.c.campaign_id)).subquery()
            rows = conn.execute(sa.select(c.c.name, c.c.head_posterior_id, c.c.revision, newest.c.pid)
                                .select_from(c.outerjoin(newest, newest.c.campaign_id == c.c.id)))
            for name, head, rev, pid in rows:
                if head != pid:
                    problems.append(f"campaign {name}: head posterior {head}, newest posterior {pid}")
            n_cut = (sa.select(T.cut.c.campaign_id, sa.func.count().label("n"), sa.func.max(T.cut.c.seq).label("top"))
                     .group_by(T.cut.c.campaign_id)).subquery()
            for name, n, top in conn.execute(sa.select(c.c.name, n_cut.c.n, n_cut.c.top)
                                             .select_from(c.join(n_cut, n_cut.c.campaign_id == c.c.id))):
                if top != n - 1:
                    problems.append(f"campaign {name}: cut seq not 0..{n - 1}")
            over = conn.execute(sa.select(c.c.name, p.c.id).select_from(c.join(p, p.c.campaign_id == c.c.id))
                                .where(p.c.n_rows > sa.select(sa.func.count()).select_from(T.cut)
                                       .where(T.cut.c.campaign_id == c.c.id).scalar_subquery())).all()
            problems += [f"campaign {n}: posterior {i} uses more cut rows than stored" for n, i in over]
        return problems


def cuts_from_rows(rows: Sequence[dict]) -> PointSet:
    """A :class:`PointSet` of cut rows as :meth:`Store.cut_rows` returns them (NULL → NaN): the cuts file as
    it was given, with the condition columns (``conditions``) and the ``stickout_mm`` column (``extra``, mm as
    exact text) of the cuts that have their own; a column no cut fills is left out, as a file without it."""
    conditions, extra = {}, {}
    for name in SETTINGS:
        col = [r.get(name) for r in rows]  # rows of an export from before migration 0003 have none
        if all(v is None for v in col):
            continue
        if name == "milling":
            conditions[name] = np.array([v or "" for v in col], dtype=object)
        elif name == STICKOUT:
            from millstab.io.stickout import stickout_cells

            extra[name] = stickout_cells([_nan(v) for v in col])
        else:
            conditions[name] = np.array([_nan(v) for v in col], dtype=float)
    return PointSet(np.array([r["rpm"] for r in rows], float), np.array([r["depth_mm"] for r in rows], float),
                    np.array([r["label"] for r in rows], dtype=object), np.array([r["weight"] for r in rows], float),
                    None, np.array([_nan(r["chatter_hz"]) for r in rows]), np.array([_nan(r["grade"]) for r in rows]),
                    np.array([r["batch"] for r in rows], dtype=object), extra=extra, conditions=conditions)


# -- SQLite connection setup ---------------------------------------------------------------------------------

def _create_private(path: Path) -> None:
    """Make a new database file owner-only (0600) before SQLite opens it (an empty file is an empty database;
    SQLite gives its -wal and -shm files the database file's mode). The file holds every shop's campaigns, which
    the app's accounts keep apart: made with the usual umask (0644) any account of the machine could read it.
    An existing file is left as it is; a folder that refuses the file is SQLite's to report (one line)."""
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    except OSError:  # it exists (another writer made it meanwhile), or the folder is read-only
        pass


def _sqlite_connect(dbapi_conn, _record) -> None:
    dbapi_conn.isolation_level = None  # the driver's own BEGIN handling off: _sqlite_begin emits it
    cur = dbapi_conn.cursor()
    cur.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
    cur.execute("PRAGMA foreign_keys = ON")
    cur.execute("PRAGMA synchronous = FULL")
    try:
        cur.execute("PRAGMA journal_mode = WAL")  # persistent in the file; a read-only file keeps its mode
    except Exception:  # noqa: BLE001 - reads still work; a write then fails with a clear error
        pass
    cur.close()


def _sqlite_begin(conn: sa.Connection) -> None:
    # a writer takes the write lock at BEGIN: the stale check and the write it guards are one atomic step,
    # and a second writer waits (busy timeout) instead of failing at its first write
    conn.exec_driver_sql("BEGIN IMMEDIATE" if conn.get_execution_options().get("shopdb_write") else "BEGIN")


def _translate(url: str, doing: str, exc: sa_exc.DBAPIError) -> InputError:
    """A database error as one line naming ``--db`` and what to do."""
    msg = str(exc.orig).strip().splitlines()[0] if exc.orig is not None else str(exc)
    low = msg.lower()
    if "readonly" in low or "read-only" in low or "read only" in low:
        return InputError("--db", url,
                          f"the database is read-only ({msg}); nothing was recorded; use a writable copy or "
                          "ask for write access to the file and its folder")
    if "disk is full" in low or "no space" in low or "disk full" in low:
        return InputError("--db", url, f"the disk is full ({msg}); nothing was recorded; free space and re-run")
    if "unable to open" in low:
        return InputError("--db", url,
                          f"the database cannot be opened or created ({msg}); check the path and that its folder "
                          "is writable")
    if "locked" in low or "busy" in low:
        return InputError("--db", url,
                          f"the database stayed locked by another writer for {BUSY_TIMEOUT_S:g} s ({msg}); re-run")
    if isinstance(exc, sa_exc.IntegrityError):  # two writers created the same campaign/cut at once (PostgreSQL)
        return StaleError("--db", url, f"another writer changed the campaign at the same moment ({msg}); nothing "
                                       "was recorded; re-run")
    if "not a database" in low or "malformed" in low:
        return InputError("--db", url, f"not a millstab shop database, or a damaged one ({msg})")
    return InputError("--db", url, f"could not {doing} the database: {msg}")


# -- migrations ----------------------------------------------------------------------------------------------

MIGRATIONS = Path(__file__).parent / "migrations"


def alembic_config(conn: sa.Connection | None = None):
    """An Alembic config whose scripts are the package's ``migrations`` (no alembic.ini)."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    cfg.attributes["connection"] = conn
    return cfg


def schema_revision(store: Store) -> str | None:
    """The database's Alembic revision (``None`` for an empty database)."""
    with store.transaction() as conn:
        if not sa.inspect(conn).has_table("alembic_version"):
            tables = sa.inspect(conn).get_table_names()
            if tables:
                raise InputError("--db", store.url, f"a database of something else (tables {', '.join(tables[:6])}) "
                                                    "and no millstab schema; give a new file or a millstab shop "
                                                    "database")
            return None
        return conn.execute(sa.text("SELECT version_num FROM alembic_version")).scalar()


def migrate(store: Store) -> None:
    """Bring the schema to the newest revision (``alembic upgrade head``), in one write transaction; a
    database already at :data:`~millstab.shopdb.schema.HEAD` is left alone without loading Alembic."""
    rev = schema_revision(store)
    if rev == T.HEAD:
        return
    from alembic import command
    from alembic.script import ScriptDirectory

    known = {s.revision for s in ScriptDirectory.from_config(alembic_config()).walk_revisions()}
    if rev is not None and rev not in known:
        raise InputError("--db", store.url, f"its schema revision {rev!r} is newer than this millstab knows "
                                            f"({T.HEAD!r}); upgrade millstab")
    with store.transaction(write=True) as conn:
        if conn.dialect.name == "postgresql":  # two first opens at once: the second waits, then finds it done
            conn.execute(sa.text("SELECT pg_advisory_xact_lock(3131)"))
        command.upgrade(alembic_config(conn), "head")


__all__ = ["BUSY_TIMEOUT_S", "Event", "Head", "MAX_HISTORY", "SETTINGS", "Snapshot", "StaleError", "Store",
           "alembic_config", "code_version", "cut_settings", "cuts_from_rows", "data_hash", "default_user", "json_text",
           "migrate", "now", "schema_revision"]
