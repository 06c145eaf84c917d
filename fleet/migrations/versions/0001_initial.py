"""The initial fleet schema.

Revision ID: 0001
Revises:
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from fleet.clock import UtcDateTime

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "rooms",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False, unique=True),
        sa.Column("floor_color", sa.String(32), nullable=True),
    )
    op.create_table(
        "beacons",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("mac_address", sa.String(17), nullable=False, unique=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("room_id", sa.Integer(), sa.ForeignKey("rooms.id"), nullable=False),
        sa.Column("rssi_threshold_dbm", sa.Integer(), nullable=False),
        sa.Column("is_base", sa.Boolean(), nullable=False),
        sa.Column("is_active", sa.Boolean(), nullable=False),
    )
    op.create_index("ix_beacons_room_id", "beacons", ["room_id"])
    op.create_table(
        "customers",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False),
        sa.Column("room_id", sa.Integer(), sa.ForeignKey("rooms.id"), nullable=True),
        sa.Column("beacon_id", sa.Integer(), sa.ForeignKey("beacons.id"), nullable=True),
    )
    op.create_table(
        "robots",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(100), nullable=False, unique=True),
        sa.Column("is_active", sa.Boolean(), nullable=False),
        sa.Column("is_offline", sa.Boolean(), nullable=False),
        sa.Column("emergency_stop", sa.Boolean(), nullable=False),
        sa.Column("maintenance_mode", sa.Boolean(), nullable=False),
        sa.Column("current_request_id", sa.Integer(), nullable=True),
        sa.Column("last_ping_at", UtcDateTime(), nullable=True),
        sa.Column("last_assigned_at", UtcDateTime(), nullable=True),
        sa.Column("weight_kg", sa.Float(), nullable=True),
        sa.Column("ultrasonic_distance", sa.Float(), nullable=True),
        sa.Column("is_in_target", sa.Boolean(), nullable=False),
    )
    op.create_table(
        "requests",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("customer_id", sa.Integer(), sa.ForeignKey("customers.id"), nullable=False),
        sa.Column("status", sa.String(40), nullable=False),
        sa.Column("is_approved", sa.Boolean(), nullable=False),
        sa.Column("assigned_robot_id", sa.Integer(), sa.ForeignKey("robots.id"), nullable=True),
        sa.Column("created_at", UtcDateTime(), nullable=False),
        sa.Column("status_changed_at", UtcDateTime(), nullable=False),
        sa.Column("accepted_at", UtcDateTime(), nullable=True),
        sa.Column("arrived_at", UtcDateTime(), nullable=True),
        sa.Column("washing_started_at", UtcDateTime(), nullable=True),
        sa.Column("finished_at", UtcDateTime(), nullable=True),
        sa.Column("weight_kg", sa.Float(), nullable=True),
        sa.Column("overweight", sa.Boolean(), nullable=False),
        sa.Column("is_paid", sa.Boolean(), nullable=False),
        sa.Column("refund_due", sa.Boolean(), nullable=False),
        sa.Column("cancel_reason", sa.String(200), nullable=True),
        sa.Column("cancelled_from", sa.String(40), nullable=True),
        sa.Column("disposition", sa.String(40), nullable=False),
        sa.Column("robot_returned", sa.Boolean(), nullable=False),
        sa.Column("admin_alert", sa.String(200), nullable=True),
    )
    op.create_index("ix_requests_customer_id", "requests", ["customer_id"])
    op.create_index("ix_requests_status", "requests", ["status"])
    op.create_table(
        "notifications",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("created_at", UtcDateTime(), nullable=False),
        sa.Column("recipient", sa.String(20), nullable=False),
        sa.Column("level", sa.String(20), nullable=False),
        sa.Column("kind", sa.String(60), nullable=False),
        sa.Column("message", sa.Text(), nullable=False),
        sa.Column("customer_id", sa.Integer(), nullable=True),
        sa.Column("request_id", sa.Integer(), nullable=True),
        sa.Column("robot_name", sa.String(100), nullable=True),
    )
    op.create_index("ix_notifications_request_id", "notifications", ["request_id"])
    op.create_table(
        "settings",
        sa.Column("key", sa.String(60), primary_key=True),
        sa.Column("value", sa.Text(), nullable=False),
    )


def downgrade() -> None:
    for table in ("settings", "notifications", "requests", "robots", "customers", "beacons",
                  "rooms"):
        op.drop_table(table)
