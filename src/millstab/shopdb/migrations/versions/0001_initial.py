"""The first schema: machines, tools, campaigns, configs, posteriors, cuts, recommendations, events.

Revision ID: 0001
Revises:
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None

TIME = sa.String(32)


def _who() -> list:
    return [sa.Column("created_at", TIME, nullable=False), sa.Column("created_by", sa.String(100), nullable=False)]


def upgrade() -> None:
    for name in ("machine", "tool"):
        op.create_table(name, sa.Column("id", sa.Integer, primary_key=True),
                        sa.Column("name", sa.String(200), nullable=False),
                        sa.Column("note", sa.Text, nullable=False, server_default=""), *_who(),
                        sa.PrimaryKeyConstraint("id", name=f"pk_{name}"),
                        sa.UniqueConstraint("name", name=f"uq_{name}_name"))
    op.create_table("campaign", sa.Column("id", sa.Integer),
                    sa.Column("name", sa.String(200), nullable=False),
                    sa.Column("machine_id", sa.Integer, nullable=True),
                    sa.Column("tool_id", sa.Integer, nullable=True),
                    sa.Column("note", sa.Text, nullable=False, server_default=""), *_who(),
                    sa.Column("updated_at", TIME, nullable=False),
                    sa.Column("revision", sa.Integer, nullable=False, server_default="0"),
                    sa.Column("head_posterior_id", sa.Integer, nullable=True),
                    sa.PrimaryKeyConstraint("id", name="pk_campaign"),
                    sa.UniqueConstraint("name", name="uq_campaign_name"),
                    sa.ForeignKeyConstraint(["machine_id"], ["machine.id"], name="fk_campaign_machine_id_machine"),
                    sa.ForeignKeyConstraint(["tool_id"], ["tool.id"], name="fk_campaign_tool_id_tool"))
    op.create_table("config", sa.Column("id", sa.Integer),
                    sa.Column("campaign_id", sa.Integer, nullable=False),
                    sa.Column("sha256", sa.String(64), nullable=False),
                    sa.Column("toml", sa.Text, nullable=False), *_who(),
                    sa.PrimaryKeyConstraint("id", name="pk_config"),
                    sa.UniqueConstraint("campaign_id", "sha256", name="uq_config_campaign_sha256"),
                    sa.ForeignKeyConstraint(["campaign_id"], ["campaign.id"], name="fk_config_campaign_id_campaign"))
    op.create_table("posterior", sa.Column("id", sa.Integer),
                    sa.Column("campaign_id", sa.Integer, nullable=False),
                    sa.Column("parent_id", sa.Integer, nullable=True),
                    sa.Column("config_id", sa.Integer, nullable=False),
                    sa.Column("n_rows", sa.Integer, nullable=False),
                    sa.Column("engine", sa.String(32), nullable=False),
                    sa.Column("samples", sa.Integer, nullable=False),
                    sa.Column("seed", sa.Integer, nullable=True),
                    sa.Column("code_version", sa.String(100), nullable=False),
                    sa.Column("data_hash", sa.String(64), nullable=False),
                    sa.Column("doc", sa.Text, nullable=False), *_who(),
                    sa.PrimaryKeyConstraint("id", name="pk_posterior"),
                    sa.ForeignKeyConstraint(["campaign_id"], ["campaign.id"], name="fk_posterior_campaign_id_campaign"),
                    sa.ForeignKeyConstraint(["parent_id"], ["posterior.id"], name="fk_posterior_parent_id_posterior"),
                    sa.ForeignKeyConstraint(["config_id"], ["config.id"], name="fk_posterior_config_id_config"))
    op.create_index("ix_posterior_campaign_id", "posterior", ["campaign_id", "id"])
    op.create_table("cut", sa.Column("id", sa.Integer),
                    sa.Column("campaign_id", sa.Integer, nullable=False),
                    sa.Column("seq", sa.Integer, nullable=False),
                    sa.Column("rpm", sa.Float, nullable=False),
                    sa.Column("depth_mm", sa.Float, nullable=False),
                    sa.Column("label", sa.String(8), nullable=False),
                    sa.Column("grade", sa.Float, nullable=True),
                    sa.Column("weight", sa.Float, nullable=False),
                    sa.Column("chatter_hz", sa.Float, nullable=True),
                    sa.Column("batch", sa.String(100), nullable=False, server_default=""),
                    sa.Column("rater", sa.String(100), nullable=False, server_default=""),
                    sa.Column("recording", sa.Text, nullable=False, server_default=""),
                    sa.Column("posterior_id", sa.Integer, nullable=True), *_who(),
                    sa.PrimaryKeyConstraint("id", name="pk_cut"),
                    sa.UniqueConstraint("campaign_id", "seq", name="uq_cut_campaign_seq"),
                    sa.ForeignKeyConstraint(["campaign_id"], ["campaign.id"], name="fk_cut_campaign_id_campaign"),
                    sa.ForeignKeyConstraint(["posterior_id"], ["posterior.id"], name="fk_cut_posterior_id_posterior"))
    op.create_table("recommendation", sa.Column("id", sa.Integer),
                    sa.Column("campaign_id", sa.Integer, nullable=False),
                    sa.Column("posterior_id", sa.Integer, nullable=False),
                    sa.Column("doc", sa.Text, nullable=False), *_who(),
                    sa.PrimaryKeyConstraint("id", name="pk_recommendation"),
                    sa.ForeignKeyConstraint(["campaign_id"], ["campaign.id"],
                                            name="fk_recommendation_campaign_id_campaign"),
                    sa.ForeignKeyConstraint(["posterior_id"], ["posterior.id"],
                                            name="fk_recommendation_posterior_id_posterior"))
    op.create_index("ix_recommendation_campaign_id", "recommendation", ["campaign_id", "id"])
    op.create_table("event", sa.Column("id", sa.Integer),
                    sa.Column("campaign_id", sa.Integer, nullable=True),
                    sa.Column("at", TIME, nullable=False),
                    sa.Column("user", sa.String(100), nullable=False),
                    sa.Column("action", sa.String(32), nullable=False),
                    sa.Column("detail", sa.Text, nullable=False, server_default=""),
                    sa.Column("posterior_id", sa.Integer, nullable=True),
                    sa.Column("recommendation_id", sa.Integer, nullable=True),
                    sa.PrimaryKeyConstraint("id", name="pk_event"),
                    sa.ForeignKeyConstraint(["campaign_id"], ["campaign.id"], name="fk_event_campaign_id_campaign"))
    op.create_index("ix_event_campaign_id", "event", ["campaign_id", "id"])


def downgrade() -> None:
    for name in ("event", "recommendation", "cut", "posterior", "config", "campaign", "tool", "machine"):
        op.drop_table(name)
