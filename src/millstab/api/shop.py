"""Shop memory as services: update, recommend and read a campaign kept in a database (docs/shopdb.md).

``db`` is a file path (SQLite), a SQLAlchemy URL, or an open :class:`millstab.shopdb.store.Store`.
:func:`update_in_db` is the file workflow (``millstab update CONFIG CUTS --start post.json``) with the
database holding the cuts and the posteriors: the same seed gives the same posterior, bit for bit.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from millstab.api.inputs import modal
from millstab.api.update import UpdateSettings
from millstab.progress import Progress
from millstab.errors import InputError
from millstab.io.config import config_to_toml
from millstab.config import Config
from millstab.io.text import read_text
from millstab.io.stickout import COLUMN as STICKOUT
from millstab.points import CONDITION_COLUMNS, PointSet
from millstab.shopdb import DEFAULT_SHOP, CutsBy, check_shop  # (the package's __init__ imports no SQLAlchemy)


def open_db(db, user: str | None = None, create: bool = True):
    """An open :class:`~millstab.shopdb.store.Store` (``db`` itself when it is one); ``create=False``: a
    database file that does not exist is an error (for the commands that only read)."""
    if hasattr(db, "record_update"):
        return db
    from millstab.shopdb import open_store

    return open_store(db, user, create)


def config_text(cfg: Config) -> str:
    """The config text recorded with an update: the file as the user wrote it (a modal config or a ``[tool]`` +
    ``[holder]`` config read from a file), else the TOML of its modal structure
    (:func:`millstab.io.config.config_to_toml`)."""
    from millstab.update.stickout import over_holder

    path = getattr(cfg, "path", None)
    holder = over_holder(cfg)  # [tool] + [holder]: its file is the config (the TOML writer knows no holder)
    if (cfg.structure.is_modal or holder) and path is not None and Path(path).is_file():
        return read_text(Path(path), "config", "UTF-8 text (TOML) file")
    if holder:
        raise InputError("config", cfg.name, "a [tool] + [holder] config is recorded as the text of its file: give "
                                             "it as a file (or its text as config_toml=)")
    return config_to_toml(modal(cfg)[0])


def _join(a: PointSet | None, b: PointSet | None) -> PointSet:
    """The cuts of ``a`` then ``b``, with their condition columns and extra columns (``stickout_mm``): a column
    only one of them has is empty (the config's value) in the other's rows."""
    parts = [p for p in (a, b) if p is not None and len(p)]
    if not parts:
        return PointSet(np.zeros(0), np.zeros(0))
    if len(parts) == 1:
        return parts[0]
    x, y = parts

    def cat(ox: dict, oy: dict, empty) -> dict:
        names = list(dict.fromkeys([*ox, *oy]))
        return {k: np.r_[ox.get(k, np.full(len(x), empty(k), dtype=object)).astype(object),
                         oy.get(k, np.full(len(y), empty(k), dtype=object)).astype(object)] for k in names}

    conditions = cat(x.conditions, y.conditions, lambda k: "" if k == "milling" else np.nan)
    extra = cat(x.extra, y.extra, lambda k: "")
    return PointSet(np.r_[x.rpm, y.rpm], np.r_[x.depth_mm, y.depth_mm], np.r_[x.label, y.label],
                    np.r_[x.weight, y.weight], x.source, np.r_[x.chatter_hz, y.chatter_hz], np.r_[x.grade, y.grade],
                    np.r_[x.batch, y.batch], extra=extra, conditions=conditions)


def _identity(cuts: PointSet, recordings: Sequence[str]) -> list[tuple]:
    """Per cut, what the user wrote of it: speed [rpm], depth [mm], weight, test day, its own condition and
    stickout, the recording it was heard in and, for a cut not heard (no recording), its label, grade and chatter
    frequency [Hz] as written. A heard cut's label and chatter frequency are derived (another config or millstab
    version hears 300.13 Hz as 300.00 Hz): they do not make it another cut."""
    from millstab.shopdb.store import cut_settings

    def num(x) -> float | None:
        return None if np.isnan(x) else float(x)

    own = cut_settings(cuts)
    return [(float(cuts.rpm[i]), float(cuts.depth_mm[i]), float(cuts.weight[i]), str(cuts.batch[i]),
             json.dumps(own[i], sort_keys=True), str(recordings[i]),
             None if recordings[i] else (str(cuts.label[i]), num(cuts.grade[i]), num(cuts.chatter_hz[i])))
            for i in range(len(cuts))]


def _heard_text(label: str, hz: float) -> str:
    return label + (f" at {hz:.2f} Hz" if np.isfinite(hz) else "")


def already_recorded(old: PointSet, given: PointSet, rows: Sequence[dict] | None = None
                     ) -> tuple[PointSet, tuple[str, ...]]:
    """The rows of ``given`` that are new, and notes. The rows that begin ``given`` and are, each, a cut the campaign
    holds (``old``, one recorded cut for one given row; the same speed, depth, weight, test day, condition,
    stickout, and recording or written label: :func:`_identity`) are not new: the file workflow passes the whole
    cuts file each time, and cuts recorded meanwhile (``listen --db``) may be missing from it. A given row that
    is not a recorded cut ends that beginning: it and every row after it are new. ``rows``: the recorded cut
    rows (:attr:`~millstab.shopdb.store.Snapshot.rows`: their recordings); without them no recorded cut was heard.
    A recorded cut heard again with another label or chatter frequency is kept as recorded (a campaign's cuts are
    never changed) and said in a note."""
    if not len(old) or not len(given):
        return given, ()
    refs_old = [str(r.get("recording") or "") for r in rows] if rows is not None else [""] * len(old)
    refs_new = [str(x) for x in (given.extra or {}).get("recording", [""] * len(given))]
    pool: dict[tuple, list[int]] = {}
    for j, key in enumerate(_identity(old, refs_old)):
        pool.setdefault(key, []).append(j)
    pairs = []
    for i, key in enumerate(_identity(given, refs_new)):
        if not pool.get(key):
            break
        pairs.append((i, pool[key].pop(0)))
    if not pairs:
        return given, ()
    k = len(pairs)
    notes = [f"the first {k} rows of the cuts are cuts the campaign holds (the same speed, depth, condition, "
             f"stickout, test day and label or recording): not added again; adding the {len(given) - k} after them"]
    for i, j in pairs:
        was, now = (old.label[j], old.chatter_hz[j]), (given.label[i], given.chatter_hz[i])
        if was[0] != now[0] or not np.isclose(was[1], now[1], rtol=0, atol=0.005, equal_nan=True):
            notes.append(f"cut {j + 1} ({old.rpm[j]:g} rpm, {old.depth_mm[j]:g} mm, {Path(refs_new[i]).name}) is "
                         f"heard as {_heard_text(*now)} now, recorded as {_heard_text(*was)}: the recorded cut is "
                         "kept (a campaign's cuts are never changed)")
    return given.subset(np.arange(k, len(given))), tuple(notes)


@dataclass(frozen=True)
class ShopUpdate:
    """What :func:`update_in_db` recorded."""

    campaign: str
    posterior: object  # millstab.update.Posterior
    posterior_id: int
    parent_id: int | None  # the posterior it started from (None: a fresh update from the prior)
    new_cuts: int
    cuts: int  # cut rows of the campaign after the update
    attempts: int  # 1, or more when another update landed first and this one re-ran from it
    notes: tuple[str, ...] = field(default=())


def _why_fresh(snap, cfg_sha: str, engine: str, new: PointSet, options: dict | None = None) -> str | None:
    """Why the head posterior cannot start this update (``None`` when it can); ``options``: the update's engine
    options (a posterior fitted with others samples another likelihood)."""
    if snap is None or snap.head.posterior_id is None:
        return None
    if snap.head.config_sha256 != cfg_sha:
        return "the config differs from the last update's"
    if snap.head.engine != engine:
        return f"the engine differs from the last update's ({snap.head.engine})"
    doc = snap.posterior_doc or {}
    had = doc.get("engine_options", (doc.get("diagnostics") or {}).get("engine_options")) or {}
    if dict(had) != dict(options or {}):
        return f"the engine options differ from the last update's ({had or 'none'})"
    post_rows = (snap.posterior_doc.get("cuts") or {}).get("label") or []
    if (new.label == "").any() or sum(1 for x in snap.rows if x["label"] == "") != sum(1 for x in post_rows if not x):
        return "boundary points were added"
    return None


Shops = Sequence[str] | None  # the shops whose campaigns the caller may see and write; None: every campaign


def _readable(store, campaign: str, shops: Shops) -> None:
    """Refuse a campaign not of ``shops`` with the words of a campaign that does not exist (a user cannot tell
    another shop's campaign from none, whatever name they guess)."""
    if shops is not None and store.campaign_shop(campaign) not in set(shops):
        raise store.unknown(campaign, shops)


#: a write to a name of another shop's campaign (the names are unique in a database)
TAKEN = "the name is taken by a campaign you cannot see; choose another name"


def _writable(store, campaign: str, shops: Shops, shop: str | None) -> str | None:
    """The shop to record ``campaign`` under: its own (which must be one of ``shops``), or for a new campaign
    ``shop`` (one of ``shops``; by default the caller's only shop). ``None``: no rule (every shop's
    campaigns, the command line). The writer's transaction checks the shop again
    (:meth:`~millstab.shopdb.store.Store.record_update`)."""
    if shops is None:  # the command line: every campaign; --shop names a new campaign's shop
        have = store.campaign_shop(campaign) if shop is not None else None
        if have is not None and have != shop:
            raise InputError("--shop", shop,
                             f"campaign {campaign!r} belongs to shop {have!r} (a campaign's shop is set "
                             "when it is created; to move it: campaign export, then import --shop)")
        return shop
    have = store.campaign_shop(campaign)
    allowed = list(dict.fromkeys(shops))
    if have is not None:
        if have not in allowed:  # a write must say why it cannot create the name; it shows nothing of the campaign
            raise InputError("--campaign", campaign, TAKEN)
        return have
    if shop is None:
        if len(allowed) != 1:
            raise InputError("shop", None, f"a new campaign needs its shop: one of {', '.join(allowed) or '(none)'}")
        shop = allowed[0]
    if shop not in allowed:
        raise InputError("shop", shop, f"one of your shops: {', '.join(allowed) or '(none)'}")
    return shop



def _grouped(settings: UpdateSettings | None, by: CutsBy | None, given: dict) -> tuple[UpdateSettings, CutsBy]:
    """``settings`` and ``by`` (defaults when ``None``) with the fields ``given`` as keywords over them
    (``seed=2, user="bob"``); TypeError naming a keyword that is a field of neither."""
    out = []
    for obj, kind in ((settings, UpdateSettings), (by, CutsBy)):
        names = {f.name for f in dataclasses.fields(kind)}
        out.append(dataclasses.replace(obj or kind(), **{k: given.pop(k) for k in list(given) if k in names}))
    if given:
        raise TypeError(f"update_in_db() got an unexpected keyword argument {next(iter(given))!r}")
    return out[0], out[1]


def update_in_db(db, campaign: str, cfg: Config, new_cuts: PointSet | None = None, points: PointSet | None = None, *,
                 settings: UpdateSettings | None = None, by: CutsBy | None = None, shops: Shops = None,
                 shop: str | None = None, config_toml: str | None = None, retries: int = 1,
                 progress: Progress | None = None, client=None, **fields) -> ShopUpdate:
    """Update campaign ``campaign`` with ``new_cuts`` (and boundary ``points``) and record it.

    Reads the campaign's cuts and current posterior in one transaction, runs :func:`millstab.api.update`
    over all cuts (old, then new) with ``start=`` the current posterior (only the new cuts are tempered in;
    a fresh update from the prior when the config, engine or engine options changed or boundary points were
    added), and records the new cuts and the posterior in one transaction. ``new_cuts`` may also be the whole
    cuts file (the file workflow's habit): its rows that begin it and are recorded cuts (what the user wrote of
    them: :func:`already_recorded`) are not added again, only the rows after them. Each cut's own condition
    columns and ``stickout_mm`` (:mod:`millstab.io.stickout`) are recorded with it and used as the file workflow
    uses them (a ``[tool]`` + ``[holder]`` config: one posterior over the holder).

    Args:
        settings: how the update samples (:class:`millstab.api.update.UpdateSettings`: engine, samples, seed,
            sampler, engine_options; the defaults of :func:`millstab.api.update`).
        by: who records the update and the new cuts' machine, tool, raters and recordings
            (:class:`millstab.shopdb.CutsBy`).
        fields: fields of ``settings`` or ``by`` as keywords, over them (``seed=1, user="ann"``: the short form
            of docs/shopdb.md); a keyword that is neither is a TypeError.
        shops: the caller may only see and write these shops' campaigns (the app's accounts; ``None``: all).
        shop: the shop of a new campaign.
        config_toml: the config text to record (default :func:`config_text` of ``cfg``; the app passes the
            campaign's own text when its form holds that config, so that the update continues from the current
            posterior).
        retries: when another update landed meanwhile, re-run from that one up to this many times, then raise
            :class:`~millstab.shopdb.store.StaleError`.
        progress, client: as :func:`millstab.api.update` (where and how it runs; not recorded).

    Raises:
        InputError: bad cuts or config (as :func:`millstab.api.update`), no cuts at all, no new cuts for a current
            posterior that would be reused as it is, a database error.
        StaleError: still stale after ``retries`` re-runs.
    """
    import hashlib

    from millstab.api.update import update
    from millstab.shopdb.store import StaleError

    from millstab.io.stickout import stickouts
    from millstab.update.stickout import over_holder

    settings, by = _grouped(settings, by, fields)
    store = open_db(db, by.user)
    shop = _writable(store, campaign, shops, shop)
    if not over_holder(cfg):  # a prior over the holder needs no tip modes (as api.update)
        cfg, _ = modal(cfg)
    toml = config_text(cfg) if config_toml is None else config_toml
    sha = hashlib.sha256(toml.encode("utf-8")).hexdigest()
    new = _join(new_cuts, points)
    notes: list[str] = []
    first = store.snapshot(campaign, with_posterior=False)
    if first is not None:
        new, seen = already_recorded(first.cuts, new, first.rows)
        notes += seen
    elif store.campaigns(shops):  # a misspelt --campaign starts a campaign of its own from the prior: say so
        gone = store.unknown(campaign, shops).allowed.split("; `millstab")[0].removeprefix("no such campaign ")
        notes.append(f"new campaign {campaign!r} {gone} (a misspelt --campaign starts a campaign of its own)")
    for attempt in range(1, retries + 2):
        if attempt > 1:  # what landed first may be another shop's new campaign of this name: never sample its cuts
            _writable(store, campaign, shops, shop)
        snap = store.snapshot(campaign)
        old = snap.cuts if snap is not None else PointSet(np.zeros(0), np.zeros(0))
        cuts = _join(old, new)
        if not len(cuts):
            raise InputError("cuts", "none", f"campaign {campaign!r} holds no cuts yet; give the cuts to record")
        why = _why_fresh(snap, sha, settings.engine, new, settings.engine_options)
        start = snap.posterior() if snap is not None and snap.posterior_doc is not None and why is None else None
        if start is not None and not len(new) and len((start.cuts or {}).get("rpm") or []) >= len(cuts):
            # nothing to temper in: the same posterior again, recorded as a new one (the app refuses it too)
            raise InputError("cuts", "none new", f"campaign {campaign!r}: its current posterior already holds all "
                                                 f"{len(cuts)} recorded cuts; give new cuts (or record some with "
                                                 "`millstab listen --db`); a changed config, engine or engine option "
                                                 "refits from the prior")
        if why is not None:
            notes.append(f"updating from the prior over all {len(cuts)} cuts: {why}")
        so = stickouts(cuts)  # each cut's stickout [m] (NaN: the config's), as `millstab update` reads it
        post = update(cfg, cuts, None, start=start, progress=progress, client=client,
                      stickout_mm=None if so is None else so * 1e3, **settings.keywords())
        head = snap.head if snap is not None else None
        try:
            pid = store.record_update(campaign, toml, new, post, expected_head=head.posterior_id if head else None,
                                      expected_rows=head.n_rows if head else 0,
                                      parent=head.posterior_id if start is not None else None, seed=settings.seed,
                                      by=by, all_cuts=cuts, note="; ".join(notes), shop=shop)
        except StaleError as exc:
            if attempt > retries:
                raise
            notes.append(f"{exc.allowed.split(';')[0]}: re-ran from it")
            continue
        return ShopUpdate(campaign, post, pid, head.posterior_id if start is not None else None, len(new), len(cuts),
                          attempt, tuple(notes))
    raise AssertionError("unreachable")


def posterior_from_db(db, campaign: str, user: str | None = None, shops: Shops = None):
    """(posterior id, :class:`~millstab.update.Posterior`) of the campaign's current posterior (for ``map``,
    ``predict``, ``listen``); ``shops``: as in :func:`update_in_db`."""
    store = open_db(db, user, create=False)
    _readable(store, campaign, shops)
    pid, doc = store.latest_posterior_doc(campaign)
    from millstab.api.update import posterior_from_json

    return pid, posterior_from_json(doc, f"{campaign} posterior {pid}")


def recommend_from_db(db, campaign: str, risk: float, rpm_range: tuple[float, float], *, user: str | None = None,
                      current=None, shops: Shops = None, **options):
    """The recommended cut and next test from the campaign's current posterior, recorded in the database.
    ``current``: ``(posterior id, posterior)`` of this campaign as the caller already read it
    (:func:`posterior_from_db`; default: read now). ``options``: those of :func:`millstab.api.recommend`. Returns
    ``(recommendation, recommendation id, posterior id)``."""
    from millstab.api.update import recommend

    store = open_db(db, user, create=False)
    _readable(store, campaign, shops)
    pid, post = current if current is not None else posterior_from_db(store, campaign)
    rec = recommend(post, risk, rpm_range, **options)
    rid = store.record_recommendation(campaign, rec.to_json(), pid, user=user)
    return rec, rid, pid


def record_cuts(db, campaign: str, cuts: PointSet, *, user: str | None = None, machine: str | None = None,
                tool: str | None = None, raters: Sequence[str] | None = None,
                recordings: Sequence[str] | None = None, shops: Shops = None, shop: str | None = None,
                expected_rows: int | None = None) -> int:
    """Record cuts without an update (the next :func:`update_in_db` uses them); returns the campaign's row count.
    ``shops``, ``shop``: as in :func:`update_in_db`; ``expected_rows``: refuse when the campaign does not
    hold that many rows (someone added cuts meanwhile)."""
    store = open_db(db, user)
    shop = _writable(store, campaign, shops, shop)
    return store.add_cuts(campaign, cuts, machine=machine, tool=tool, user=user, raters=raters,
                          recordings=recordings, shop=shop, expected_rows=expected_rows)


def current_posterior(db, campaign: str, user: str | None = None, shops: Shops = None):
    """``(posterior id, Posterior)`` of the campaign's current posterior, or ``None`` when the campaign does not
    exist yet or has no posterior (``listen --db`` records its cut either way)."""
    if not hasattr(db, "record_update") and "://" not in str(db) and not Path(str(db)).expanduser().exists():
        return None  # no database file yet: the cut to record creates it
    store = open_db(db, user, create=False)
    if store.campaign_shop(campaign) is None:
        return None
    _readable(store, campaign, shops)
    head = store.head(campaign)
    return None if head.posterior_id is None else posterior_from_db(store, campaign)


def heard_target(db, campaign: str, teeth: int, *, stickout_mm: float | None = None, new_campaign: bool = False,
                 user: str | None = None, shops: Shops = None):
    """Check where ``listen --db`` is to record a cut heard with ``teeth`` teeth at ``stickout_mm`` [mm] (``None``:
    the config's) before it listens; returns :func:`current_posterior` (``None``: no posterior yet).

    Raises:
        InputError: ``campaign`` does not exist in a database that holds others, without ``new_campaign`` (a typo
            made a new campaign of one cut, silently); ``teeth`` is not the campaign's tool's (its current
            posterior's condition); ``stickout_mm`` is no stickout of the campaign's tool
            (:func:`millstab.update.stickout.check_stickout_mm`) or the campaign's posterior is over the tip's
            modes (it has no stickouts: the next update would refuse the cut).
    """
    from millstab.update.stickout import check_stickout_mm, not_over_holder, stickout_mm_of

    exists = False
    if hasattr(db, "record_update") or "://" in str(db) or Path(str(db)).expanduser().exists():
        store = open_db(db, user, create=False)
        exists = store.campaign_shop(campaign) is not None
        if not exists and store.campaigns(shops) and not new_campaign:
            gone = store.unknown(campaign, shops)
            raise InputError("--campaign", campaign, f"{gone.allowed.split('; `millstab')[0]}; give --new-campaign to "
                                                     "start a campaign of that name with this cut")
    current = current_posterior(db, campaign, user, shops) if exists else None
    post = None if current is None else current[1]
    have = None if post is None else int(post.condition.teeth)
    if have is not None and int(teeth) != have:
        raise InputError("--teeth", teeth, f"the tool of campaign {campaign!r} has {have} teeth (its config); "
                                           "a cut of another tool belongs in another campaign")
    if stickout_mm is not None:
        check_stickout_mm(stickout_mm, "--stickout", None if post is None else getattr(post.prior.par, "tool", None))
        if post is not None and stickout_mm_of(post) is None:
            raise not_over_holder([float(stickout_mm) * 1e-3])
    return current


def record_heard(db, campaign: str, heard, depth_mm: float, recording, *, user: str | None = None,
                 shops: Shops = None, weight: float = 1.0, stickout_mm: float | None = None) -> int:
    """Record a cut labelled by listening (:func:`millstab.api.listen_file`'s result ``heard``) in the campaign:
    its speed (the programmed rpm), ``depth_mm``, the tool's ``stickout_mm`` [mm] (``None``: the config's), the
    label and chatter frequency heard, the rater ``listen`` and the recording by reference (its absolute path).
    Returns the campaign's number of cuts. (:func:`heard_target` checks the campaign, teeth and stickout first.)"""
    from millstab.io.stickout import stickout_cells
    from millstab.update.stickout import check_stickout_mm

    r = heard.listening
    depth = float(depth_mm)
    if not np.isfinite(depth) or depth <= 0:
        raise InputError("--depth", depth_mm, "the axial depth of the recorded cut in mm, > 0")
    hz = float(r.chatter_hz) if r.label != "stable" else float("nan")
    so = {} if stickout_mm is None else {STICKOUT: stickout_cells([check_stickout_mm(stickout_mm, "--stickout")])}
    cut = PointSet(np.array([float(r.rpm)]), np.array([depth]), np.array([r.label], dtype=object),
                   np.array([float(weight)]), None, np.array([hz]), extra=so)
    ref = str(Path(recording).expanduser().resolve()) if "://" not in str(recording) else str(recording)
    return record_cuts(db, campaign, cut, user=user, raters=["listen"], recordings=[ref], shops=shops)


def history(db, campaign: str | None = None, limit: int = 50, before: int | None = None, shops: Shops = None):
    """The newest ``limit`` events (:class:`~millstab.shopdb.store.Event`, newest first), of one campaign or all
    (of ``shops``' campaigns only, when given)."""
    store = open_db(db, create=False)
    if campaign is not None:
        _readable(store, campaign, shops)
    return store.history(campaign, limit, before, shops)


def history_table(events) -> tuple[list[str], list]:
    """(header, columns) of history events for CSV."""
    header = ["id", "at", "user", "campaign", "action", "detail"]
    return header, [[getattr(e, h) for e in events] for h in header]


#: the columns of a campaign's cuts table (:func:`cut_table`), in order; the condition and stickout columns
#: appear only when a cut has its own (an empty cell: the config's value)
OWN_COLUMNS = CONDITION_COLUMNS + (STICKOUT,)
CUT_COLUMNS = ("seq", "rpm", "depth_mm", "label", "chatter_hz", "batch", "rater") + OWN_COLUMNS + ("created_by",)


def cut_table(rows: Sequence[dict]) -> tuple[list[str], list[list]]:
    """(header, rows) of a campaign's cut rows (:attr:`OpenCampaign.rows`) for a table: the cut number (1 = the
    first), speed, depth, label, chatter frequency and test day, who rated and recorded it, and each condition
    or stickout column that some cut fills (``None`` in a cut's cell: the config's value). Columns no cut fills
    (no chatter frequency, no test day, no rater, the config's condition for every cut) are left out."""
    keep = [c for c in CUT_COLUMNS if c in ("seq", "rpm", "depth_mm", "label")
            or any(r.get(c) not in (None, "") for r in rows)]
    return keep, [[r["seq"] + 1 if c == "seq" else r.get(c) for c in keep] for r in rows]


def campaigns(db, shops: Shops = None) -> list[dict]:
    """Every campaign of the database (of ``shops`` only, when given): name, shop, machine, tool, updates, times."""
    return open_db(db, create=False).campaigns(shops)


def check(db) -> list[str]:
    """Problems found in the database (empty when consistent): :meth:`~millstab.shopdb.store.Store.check`."""
    return open_db(db, create=False).check()


def export_campaign(db, campaign: str, folder) -> Path:
    """Write a campaign as plain files (:mod:`millstab.shopdb.files`); returns the folder."""
    from millstab.shopdb.files import export_campaign as run

    return run(open_db(db, create=False), campaign, folder)


def import_campaign(db, folder, name: str | None = None, user: str | None = None, shop: str | None = None) -> str:
    """Create a campaign from an exported folder (in ``shop``, default: the shop it was exported from);
    returns its name."""
    from millstab.shopdb.files import read_campaign

    bundle = read_campaign(folder)
    if shop is not None:
        bundle["shop"] = shop
    return open_db(db, user).import_bundle(bundle, name, user)


@dataclass(frozen=True)
class OpenCampaign:
    """A campaign as one read saw it (:meth:`ShopView.open`): what the app shows when it opens one."""

    name: str
    shop: str
    revision: int  # updates landed
    cuts: PointSet  # every cut row in order (rounds, then the cuts recorded since)
    rows: list  # the same rows with rater, recording, batch, who and when
    posterior_id: int | None
    posterior: object  # the current millstab.update.Posterior, or None before the first update
    posterior_rows: int  # cut rows the current posterior used (cuts beyond it wait for the next update)
    config_toml: str | None  # the config text of the current posterior
    events: list  # the newest history events (Event), newest first
    updated_at: str
    updated_by: str | None


class ShopView:
    """A shop database as one user sees it: the campaigns of ``shops`` only (``None``: every campaign, e.g.
    the app on this machine without accounts). Every method goes through the functions above with
    ``shops``, so the rule holds in the service layer, whatever door calls it (the app's Update tab)."""

    def __init__(self, db, user: str | None = None, shops: Shops = None):
        self.store = open_db(db, user)
        self.user = self.store.user
        self.shops = None if shops is None else tuple(dict.fromkeys(shops))

    def __repr__(self) -> str:
        return f"ShopView({self.store.url!r}, user={self.user!r}, shops={self.shops!r})"

    def campaigns(self) -> list[dict]:
        return campaigns(self.store, self.shops)

    def open(self, campaign: str, events: int = 20) -> OpenCampaign:
        """Read a campaign (cuts, current posterior, its config, the newest ``events`` of its history)."""
        _readable(self.store, campaign, self.shops)
        snap = self.store.snapshot(campaign)
        if snap is None:
            raise self.store.unknown(campaign, self.shops)
        h = snap.head
        post = snap.posterior()
        used = len((snap.posterior_doc or {}).get("cuts", {}).get("label") or []) if post is not None else 0
        return OpenCampaign(campaign, self.store.campaign_shop(campaign), h.revision, snap.cuts, snap.rows,
                            h.posterior_id, post, used, snap.config_toml,
                            self.store.history(campaign, events), h.updated_at, h.updated_by)

    def update(self, campaign: str, cfg: Config, new_cuts: PointSet | None = None, **options) -> ShopUpdate:
        """:func:`update_in_db` as this user, within their shops (``shop=`` for a new campaign)."""
        return update_in_db(self.store, campaign, cfg, new_cuts, user=self.user, shops=self.shops, **options)

    def add_cuts(self, campaign: str, cuts: PointSet, **options) -> int:
        """:func:`record_cuts` as this user, within their shops."""
        return record_cuts(self.store, campaign, cuts, user=self.user, shops=self.shops, **options)

    def recommend(self, campaign: str, risk: float, rpm_range: tuple[float, float], **options):
        """:func:`recommend_from_db` as this user, within their shops."""
        return recommend_from_db(self.store, campaign, risk, rpm_range, user=self.user, shops=self.shops, **options)

    def history(self, campaign: str | None = None, limit: int = 50, before: int | None = None):
        return history(self.store, campaign, limit, before, self.shops)


__all__ = ["CUT_COLUMNS", "OWN_COLUMNS", "DEFAULT_SHOP", "CutsBy", "OpenCampaign", "check_shop", "ShopUpdate",
           "ShopView",
           "Shops", "already_recorded", "campaigns", "check", "config_text", "cut_table", "current_posterior",
           "export_campaign", "heard_target", "history", "history_table", "import_campaign", "open_db",
           "posterior_from_db", "recommend_from_db", "record_cuts", "record_heard", "update_in_db"]
