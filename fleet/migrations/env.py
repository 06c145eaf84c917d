"""Alembic environment: runs on the connection that ``fleet.db.Database.migrate`` hands over."""

from __future__ import annotations

from alembic import context
from sqlalchemy.engine import Connection

from fleet.models import Base

connection = context.config.attributes.get("connection")
if not isinstance(connection, Connection):
    msg = "run fleet migrations through fleet.db.Database.migrate()"
    raise RuntimeError(msg)
context.configure(
    connection=connection,
    target_metadata=Base.metadata,
    render_as_batch=connection.dialect.name == "sqlite",
)
with context.begin_transaction():
    context.run_migrations()
