"""poses: a field robot's reported pose every 5 s of mission time (field runs play back from them)

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-27
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0004"
down_revision: str | None = "0003"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # a new table only: every mission stored before it simply has no poses (a simulated one
    # needs none, an older field run answers playback with its events and no robots)
    op.create_table(
        "poses",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("t", sa.Float(), nullable=False),
        sa.Column("robot", sa.String(length=80), nullable=False),
        sa.Column("x", sa.Float(), nullable=False),
        sa.Column("y", sa.Float(), nullable=False),
        sa.Column("heading", sa.Float(), nullable=False),
        sa.Column("state", sa.String(length=32), nullable=False),
        sa.Column("load", sa.Integer(), nullable=False),
        sa.ForeignKeyConstraint(["mission_id"], ["missions.id"], ondelete="CASCADE"),
        sa.PrimaryKeyConstraint("id"),
    )
    with op.batch_alter_table("poses", schema=None) as batch_op:
        batch_op.create_index("ix_poses_mission_t", ["mission_id", "t"], unique=False)


def downgrade() -> None:
    with op.batch_alter_table("poses", schema=None) as batch_op:
        batch_op.drop_index("ix_poses_mission_t")
    op.drop_table("poses")
