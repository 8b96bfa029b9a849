"""initial schema

Revision ID: 0001
Revises:
Create Date: 2026-11-22
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0001"
down_revision: str | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "missions",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("scenario_name", sa.String(length=80), nullable=False),
        sa.Column("scenario", sa.JSON(), nullable=False),
        sa.Column("seed", sa.Integer(), nullable=False),
        sa.Column("policy", sa.String(length=32), nullable=False),
        sa.Column("current_policy", sa.String(length=32), nullable=False),
        sa.Column("planner", sa.String(length=16), nullable=False),
        sa.Column("status", sa.String(length=16), nullable=False),
        sa.Column("speed", sa.Float(), nullable=True),
        sa.Column("sim_time", sa.Float(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("ended_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("world_map", sa.JSON(), nullable=True),
        sa.Column("metrics", sa.JSON(), nullable=True),
        sa.Column("final_state", sa.JSON(), nullable=True),
        sa.Column("error", sa.String(length=2000), nullable=True),
        sa.PrimaryKeyConstraint("id"),
    )
    with op.batch_alter_table("missions", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_missions_status"), ["status"], unique=False)

    op.create_table(
        "actions",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("seq", sa.Integer(), nullable=False),
        sa.Column("t", sa.Float(), nullable=False),
        sa.Column("kind", sa.String(length=32), nullable=False),
        sa.Column("args", sa.JSON(), nullable=False),
        sa.Column("replay", sa.Boolean(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(["mission_id"], ["missions.id"], ondelete="CASCADE"),
        sa.PrimaryKeyConstraint("mission_id", "seq"),
    )
    op.create_table(
        "auctions",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("auction_id", sa.String(length=120), nullable=False),
        sa.Column("kind", sa.String(length=32), nullable=False),
        sa.Column("auctioneer", sa.String(length=80), nullable=False),
        sa.Column("task_type", sa.String(length=32), nullable=False),
        sa.Column("location_x", sa.Float(), nullable=False),
        sa.Column("location_y", sa.Float(), nullable=False),
        sa.Column("status", sa.String(length=16), nullable=False),
        sa.Column("opened_at", sa.Float(), nullable=False),
        sa.Column("closed_at", sa.Float(), nullable=True),
        sa.Column("allocated_to", sa.String(length=80), nullable=True),
        sa.Column("reannouncements", sa.Integer(), nullable=False),
        sa.Column("policy", sa.String(length=32), nullable=False),
        sa.Column("task_id", sa.String(length=120), nullable=True),
        sa.Column("reauction_of", sa.String(length=120), nullable=True),
        sa.ForeignKeyConstraint(["mission_id"], ["missions.id"], ondelete="CASCADE"),
        sa.PrimaryKeyConstraint("mission_id", "auction_id"),
    )
    with op.batch_alter_table("auctions", schema=None) as batch_op:
        batch_op.create_index(
            "ix_auctions_mission_opened", ["mission_id", "opened_at"], unique=False
        )

    op.create_table(
        "events",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("seq", sa.Integer(), nullable=False),
        sa.Column("t", sa.Float(), nullable=False),
        sa.Column("kind", sa.String(length=40), nullable=False),
        sa.Column("data", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(["mission_id"], ["missions.id"], ondelete="CASCADE"),
        sa.PrimaryKeyConstraint("mission_id", "seq"),
    )
    with op.batch_alter_table("events", schema=None) as batch_op:
        batch_op.create_index(
            "ix_events_mission_kind_seq", ["mission_id", "kind", "seq"], unique=False
        )

    op.create_table(
        "awards",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("auction_id", sa.String(length=120), nullable=False),
        sa.Column("idx", sa.Integer(), nullable=False),
        sa.Column("t", sa.Float(), nullable=False),
        sa.Column("winner", sa.String(length=80), nullable=False),
        sa.Column("outcome", sa.String(length=16), nullable=False),
        sa.ForeignKeyConstraint(
            ["mission_id", "auction_id"],
            ["auctions.mission_id", "auctions.auction_id"],
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("mission_id", "auction_id", "idx"),
    )
    op.create_table(
        "bids",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("auction_id", sa.String(length=120), nullable=False),
        sa.Column("idx", sa.Integer(), nullable=False),
        sa.Column("t", sa.Float(), nullable=False),
        sa.Column("bidder", sa.String(length=80), nullable=False),
        sa.Column("utility", sa.Float(), nullable=True),
        sa.Column("round", sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(
            ["mission_id", "auction_id"],
            ["auctions.mission_id", "auctions.auction_id"],
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("mission_id", "auction_id", "idx"),
    )
    with op.batch_alter_table("bids", schema=None) as batch_op:
        batch_op.create_index("ix_bids_mission_bidder", ["mission_id", "bidder"], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("bids", schema=None) as batch_op:
        batch_op.drop_index("ix_bids_mission_bidder")

    op.drop_table("bids")
    op.drop_table("awards")
    with op.batch_alter_table("events", schema=None) as batch_op:
        batch_op.drop_index("ix_events_mission_kind_seq")

    op.drop_table("events")
    with op.batch_alter_table("auctions", schema=None) as batch_op:
        batch_op.drop_index("ix_auctions_mission_opened")

    op.drop_table("auctions")
    op.drop_table("actions")
    with op.batch_alter_table("missions", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_missions_status"))

    op.drop_table("missions")
