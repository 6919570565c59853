"""The shop database's tables (SQLAlchemy Core): machines, tools, campaigns, configs, cuts, posteriors,
recommendations and the event log.

One campaign is one tool's test series on one machine (``t12-m1``). Its memory is append-only: cuts,
posteriors and recommendations are never changed or deleted; what is *current* is the campaign's
``head_posterior_id`` (the newest posterior that landed) and ``revision`` (how many updates landed), which
one transaction moves together with the rows it adds (see :mod:`millstab.shopdb.store`).

Conventions: times are UTC ISO 8601 text (``2026-11-26T22:53:00.123456Z``: sorts as time, the same on
SQLite and PostgreSQL); speeds rev/min, depths mm, frequencies Hz, as in the cuts CSV; floats are 8-byte
IEEE (SQLite REAL, PostgreSQL double precision), so a cut reads back bit-identical; NaN is stored as NULL
(SQLite cannot store NaN). JSON documents (posteriors, recommendations) are text, exactly the files
``millstab update --out`` / ``recommend --out`` write, so any SQL client can read them.

``head_posterior_id`` has no foreign-key constraint on purpose: campaign → posterior → campaign would be a
cycle that SQLite cannot create in one ``CREATE TABLE`` order; the store is its only writer and
``Store.check()`` verifies it.

The migrations in ``migrations/versions`` create these tables; a change here needs a new migration
(``tests/test_shopdb.py`` checks that the migrated schema equals this metadata).
"""

from __future__ import annotations

from sqlalchemy import (Column, Float, ForeignKey, Index, Integer, MetaData, String, Table, Text, UniqueConstraint)

from millstab.shopdb import DEFAULT_SHOP

#: the newest migration; a database at this revision is opened without running Alembic (fast path)
HEAD = "0003"

NAMING = {"ix": "ix_%(column_0_label)s", "uq": "uq_%(table_name)s_%(column_0_name)s",
          "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s", "pk": "pk_%(table_name)s"}
metadata = MetaData(naming_convention=NAMING)

TIME = String(32)  # UTC ISO 8601 with 'Z'
NAME = String(200)
USER = String(100)

machine = Table(
    "machine", metadata,
    Column("id", Integer, primary_key=True),
    Column("name", NAME, nullable=False, unique=True),
    Column("note", Text, nullable=False, server_default=""),
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
)

tool = Table(
    "tool", metadata,  # a holder + tool assembly (its tap test lives in the campaign's config)
    Column("id", Integer, primary_key=True),
    Column("name", NAME, nullable=False, unique=True),
    Column("note", Text, nullable=False, server_default=""),
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
)

campaign = Table(
    "campaign", metadata,
    Column("id", Integer, primary_key=True),
    Column("name", NAME, nullable=False, unique=True),
    Column("machine_id", Integer, ForeignKey("machine.id"), nullable=True),
    Column("tool_id", Integer, ForeignKey("tool.id"), nullable=True),
    Column("note", Text, nullable=False, server_default=""),
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
    Column("updated_at", TIME, nullable=False),
    Column("revision", Integer, nullable=False, server_default="0"),  # updates landed
    Column("head_posterior_id", Integer, nullable=True),  # the current posterior (no FK: see the docstring)
    Column("shop", String(100), nullable=False, server_default=DEFAULT_SHOP),  # who may see it (migration 0002)
)
Index("ix_campaign_shop", campaign.c.shop, campaign.c.name)

config = Table(
    "config", metadata,  # the TOML of the cutting conditions, tap-test structure and [prior]
    Column("id", Integer, primary_key=True),
    Column("campaign_id", Integer, ForeignKey("campaign.id"), nullable=False),
    Column("sha256", String(64), nullable=False),
    Column("toml", Text, nullable=False),
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
    UniqueConstraint("campaign_id", "sha256", name="uq_config_campaign_sha256"),
)

posterior = Table(
    "posterior", metadata,
    Column("id", Integer, primary_key=True),
    Column("campaign_id", Integer, ForeignKey("campaign.id"), nullable=False),
    Column("parent_id", Integer, ForeignKey("posterior.id"), nullable=True),  # the posterior it started from
    Column("config_id", Integer, ForeignKey("config.id"), nullable=False),
    Column("n_rows", Integer, nullable=False),  # it is the posterior of the campaign's cut rows seq < n_rows
    Column("engine", String(32), nullable=False),
    Column("samples", Integer, nullable=False),
    Column("seed", Integer, nullable=True),
    Column("code_version", String(100), nullable=False),  # millstab version (+ git commit when known)
    Column("data_hash", String(64), nullable=False),  # sha256 of the config text and the cut rows it used
    Column("doc", Text, nullable=False),  # the posterior JSON (schema millstab.posterior/3; /2 and /1 still load)
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
)
Index("ix_posterior_campaign_id", posterior.c.campaign_id, posterior.c.id)

cut = Table(
    "cut", metadata,
    Column("id", Integer, primary_key=True),
    Column("campaign_id", Integer, ForeignKey("campaign.id"), nullable=False),
    Column("seq", Integer, nullable=False),  # 0, 1, 2, ... in the order the cuts were made
    Column("rpm", Float, nullable=False),
    Column("depth_mm", Float, nullable=False),
    Column("label", String(8), nullable=False),  # stable | chatter | marginal | '' (boundary point)
    Column("grade", Float, nullable=True),  # graded label in [0, 1]; NULL for a boundary point
    Column("weight", Float, nullable=False),
    Column("chatter_hz", Float, nullable=True),
    Column("batch", String(100), nullable=False, server_default=""),  # test day / session
    Column("rater", USER, nullable=False, server_default=""),  # who labelled it
    Column("recording", Text, nullable=False, server_default=""),  # a reference (path/URL) to the sound
    Column("posterior_id", Integer, ForeignKey("posterior.id"), nullable=True),  # the update that brought it
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
    # the cut's own condition and stickout (migration 0003): NULL = the config's value (an empty cell)
    Column("radial_immersion", Float, nullable=True),  # a/D in (0, 1]
    Column("radial_width_mm", Float, nullable=True),  # radial width [mm] (with the config's tool diameter)
    Column("milling", String(8), nullable=True),  # up | down
    Column("entry_deg", Float, nullable=True),  # entry and exit angles [deg], given together
    Column("exit_deg", Float, nullable=True),
    Column("feed_per_tooth_mm", Float, nullable=True),  # feed per tooth [mm]
    Column("teeth", Integer, nullable=True),
    Column("stickout_mm", Float, nullable=True),  # tool stickout, holder face to tip [mm]
    UniqueConstraint("campaign_id", "seq", name="uq_cut_campaign_seq"),
)

recommendation = Table(
    "recommendation", metadata,
    Column("id", Integer, primary_key=True),
    Column("campaign_id", Integer, ForeignKey("campaign.id"), nullable=False),
    Column("posterior_id", Integer, ForeignKey("posterior.id"), nullable=False),
    Column("doc", Text, nullable=False),  # the recommendation JSON (recommended cut and next test)
    Column("created_at", TIME, nullable=False),
    Column("created_by", USER, nullable=False),
)
Index("ix_recommendation_campaign_id", recommendation.c.campaign_id, recommendation.c.id)

event = Table(
    "event", metadata,  # who did what and when
    Column("id", Integer, primary_key=True),
    Column("campaign_id", Integer, ForeignKey("campaign.id"), nullable=True),
    Column("at", TIME, nullable=False),
    Column("user", USER, nullable=False),
    Column("action", String(32), nullable=False),  # create | update | cuts | recommend | import
    Column("detail", Text, nullable=False, server_default=""),
    Column("posterior_id", Integer, nullable=True),
    Column("recommendation_id", Integer, nullable=True),
)
Index("ix_event_campaign_id", event.c.campaign_id, event.c.id)

__all__ = ["DEFAULT_SHOP", "HEAD", "campaign", "config", "cut", "event", "machine", "metadata", "posterior",
           "recommendation", "tool"]
