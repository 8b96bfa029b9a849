"""field runs outlive their server: each event's and pose's source life and number there,
and how to reach a field mission's processes again (`field_links`)

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-27
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0005"
down_revision: str | None = "0004"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("events", schema=None) as batch_op:
        batch_op.add_column(sa.Column("source", sa.String(length=80), nullable=True))
        batch_op.add_column(sa.Column("rseq", sa.BigInteger(), nullable=True))
        batch_op.create_index(
            "ix_events_mission_source_rseq", ["mission_id", "source", "rseq"], unique=False
        )
    with op.batch_alter_table("poses", schema=None) as batch_op:
        batch_op.add_column(sa.Column("source", sa.String(length=80), nullable=True))
        batch_op.add_column(sa.Column("rseq", sa.BigInteger(), nullable=True))
    op.create_table(
        "field_links",
        sa.Column("mission_id", sa.Integer(), nullable=False),
        sa.Column("key_space", sa.String(length=64), nullable=False),
        sa.Column("endpoint", sa.String(length=200), nullable=False),
        sa.Column("authority", sa.String(length=200), nullable=False),
        sa.Column("control_gen", sa.Integer(), nullable=False),
        sa.Column("world_pid", sa.Integer(), nullable=True),
        sa.ForeignKeyConstraint(["mission_id"], ["missions.id"], ondelete="CASCADE"),
        sa.PrimaryKeyConstraint("mission_id"),
    )


def downgrade() -> None:
    op.drop_table("field_links")
    with op.batch_alter_table("poses", schema=None) as batch_op:
        batch_op.drop_column("rseq")
        batch_op.drop_column("source")
    with op.batch_alter_table("events", schema=None) as batch_op:
        batch_op.drop_index("ix_events_mission_source_rseq")
        batch_op.drop_column("rseq")
        batch_op.drop_column("source")
