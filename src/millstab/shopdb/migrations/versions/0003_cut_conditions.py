"""Each cut keeps the conditions it was cut in (issue 27's per-cut condition columns) and its tool stickout
(issue 30's ``stickout_mm``), so that the database holds every cut as the cuts file gave it.

NULL = the config's value (an empty cell of the cuts file); existing cuts were all in their config's condition
and stickout, so they keep NULL. The test day (the ``batch``/``date`` column) has been stored since 0001.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-27
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None

#: (column, type): millstab.points.CONDITION_COLUMNS and the stickout [mm], each nullable
COLUMNS = (("radial_immersion", sa.Float), ("radial_width_mm", sa.Float), ("milling", sa.String(8)),
           ("entry_deg", sa.Float), ("exit_deg", sa.Float), ("feed_per_tooth_mm", sa.Float), ("teeth", sa.Integer),
           ("stickout_mm", sa.Float))


def upgrade() -> None:
    with op.batch_alter_table("cut") as batch:  # SQLite: batch mode (PostgreSQL: plain ALTER TABLE ADD COLUMN)
        for name, kind in COLUMNS:
            batch.add_column(sa.Column(name, kind, nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("cut") as batch:
        for name, _ in reversed(COLUMNS):
            batch.drop_column(name)
