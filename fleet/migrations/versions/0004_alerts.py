"""Alerts for the laundry staff (issue 27): raised, acknowledged, resolved.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from fleet.clock import UtcDateTime

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "alerts",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("created_at", UtcDateTime(), nullable=False),
        sa.Column("kind", sa.String(60), nullable=False),
        sa.Column("level", sa.String(20), nullable=False),
        sa.Column("robot_name", sa.String(100), nullable=True),
        sa.Column("request_id", sa.Integer(), nullable=True),
        sa.Column("message", sa.Text(), nullable=False),
        sa.Column("acknowledged_at", UtcDateTime(), nullable=True),
        sa.Column("acknowledged_by", sa.String(100), nullable=True),
        sa.Column("resolved_at", UtcDateTime(), nullable=True),
        sa.Column("resolved_by", sa.String(100), nullable=True),
        sa.Column("resolution", sa.String(60), nullable=True),
    )
    op.create_index("ix_alerts_robot_name", "alerts", ["robot_name"])
    op.create_index("ix_alerts_request_id", "alerts", ["request_id"])


def downgrade() -> None:
    op.drop_index("ix_alerts_request_id", "alerts")
    op.drop_index("ix_alerts_robot_name", "alerts")
    op.drop_table("alerts")
