"""A robot back at base with a load waits to be unloaded before its next job (issue 27).

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from fleet.clock import UtcDateTime

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("unload_pending", sa.Boolean(), nullable=False,
                                   server_default=sa.false()))
        batch.add_column(sa.Column("unload_clear_since", UtcDateTime(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.drop_column("unload_clear_since")
        batch.drop_column("unload_pending")
