"""Painted lines that rooms share (issue 27): at most one robot travels a shared line.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "line_rooms",
        sa.Column("line", sa.String(100), primary_key=True),
        sa.Column("room_id", sa.Integer(), sa.ForeignKey("rooms.id"), primary_key=True),
    )
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("waiting_for_line", sa.String(100), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.drop_column("waiting_for_line")
    op.drop_table("line_rooms")
