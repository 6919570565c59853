"""Alembic environment of the shop database: run programmatically by :func:`millstab.shopdb.store.migrate`
on the store's own connection (``config.attributes["connection"]``), never from an ``alembic.ini``."""

from __future__ import annotations

from alembic import context

from millstab.shopdb.schema import metadata

connection = context.config.attributes["connection"]
context.configure(connection=connection, target_metadata=metadata,
                  render_as_batch=connection.dialect.name == "sqlite")  # ALTER TABLE in SQLite needs batch mode
with context.begin_transaction():
    context.run_migrations()
