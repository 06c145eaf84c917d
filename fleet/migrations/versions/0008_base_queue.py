"""Where a robot is: its place in the base queue, or away on the line; and clean laundry
that waits for a robot to deliver it (issue 27).

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from fleet.clock import UtcDateTime

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("base_place", sa.Integer(), nullable=True))
        batch.add_column(sa.Column("has_left_base", sa.Boolean(), nullable=False,
                                   server_default=sa.true()))
    # A robot serving nothing when the server is upgraded is taken to stand at base, in the
    # order it was registered (robots serving a request are away until they are back).
    robots = sa.table("robots", sa.column("id", sa.Integer()),
                      sa.column("current_request_id", sa.Integer()),
                      sa.column("base_place", sa.Integer()))
    with op.batch_alter_table("requests") as batch:
        batch.add_column(sa.Column("washing_done_at", UtcDateTime(), nullable=True))
    op.execute(robots.update().where(robots.c.current_request_id.is_(None))
               .values(base_place=robots.c.id))


def downgrade() -> None:
    with op.batch_alter_table("requests") as batch:
        batch.drop_column("washing_done_at")
    with op.batch_alter_table("robots") as batch:
        batch.drop_column("has_left_base")
        batch.drop_column("base_place")
