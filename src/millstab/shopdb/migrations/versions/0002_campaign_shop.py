"""A campaign belongs to a shop (issue 31.4: a user of the app sees and writes only their shops' campaigns).

Existing campaigns go to the shop ``default`` (the shop of accounts that name none).

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-27
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("campaign") as batch:  # SQLite cannot ALTER a column in place: batch mode
        batch.add_column(sa.Column("shop", sa.String(100), nullable=False, server_default="default"))
    op.create_index("ix_campaign_shop", "campaign", ["shop", "name"])


def downgrade() -> None:
    op.drop_index("ix_campaign_shop", table_name="campaign")
    with op.batch_alter_table("campaign") as batch:
        batch.drop_column("shop")
