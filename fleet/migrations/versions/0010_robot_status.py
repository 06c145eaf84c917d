"""The site status of every robot (issue 29): profile, pose or place, job, when it reported;
and the code of a robot's fault alert.

Revision ID: 0010
Revises: 0009
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from fleet.clock import UtcDateTime

revision = "0010"
down_revision = "0009"
branch_labels = None
depends_on = None

_ROBOT_COLUMNS = ("profile", "pose_x_m", "pose_y_m", "pose_theta_rad", "map_name", "place",
                  "job", "status_at")


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("profile", sa.String(40), nullable=True))
        batch.add_column(sa.Column("pose_x_m", sa.Float(), nullable=True))
        batch.add_column(sa.Column("pose_y_m", sa.Float(), nullable=True))
        batch.add_column(sa.Column("pose_theta_rad", sa.Float(), nullable=True))
        batch.add_column(sa.Column("map_name", sa.String(100), nullable=True))
        batch.add_column(sa.Column("place", sa.String(100), nullable=True))
        batch.add_column(sa.Column("job", sa.String(200), nullable=True))
        batch.add_column(sa.Column("status_at", UtcDateTime(), nullable=True))
    with op.batch_alter_table("alerts") as batch:
        batch.add_column(sa.Column("code", sa.String(60), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("alerts") as batch:
        batch.drop_column("code")
    with op.batch_alter_table("robots") as batch:
        for name in reversed(_ROBOT_COLUMNS):
            batch.drop_column(name)
