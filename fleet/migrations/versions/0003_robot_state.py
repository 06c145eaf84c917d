"""What the robot reports of itself in the data exchange (issue 27): its state path, e-stop,
fault and battery.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None

_COLUMNS = ("state", "estop_active", "fault_code", "fault_message", "battery_pct")


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("state", sa.String(100), nullable=True))
        batch.add_column(sa.Column("estop_active", sa.Boolean(), nullable=True))
        batch.add_column(sa.Column("fault_code", sa.String(60), nullable=True))
        batch.add_column(sa.Column("fault_message", sa.String(500), nullable=True))
        batch.add_column(sa.Column("battery_pct", sa.Float(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        for name in reversed(_COLUMNS):
            batch.drop_column(name)
