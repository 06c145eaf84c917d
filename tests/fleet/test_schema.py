"""The Alembic migrations build exactly the schema the models describe, and re-running them
is harmless."""

from __future__ import annotations

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from fleet.db import Database
from fleet.models import Base


class TestMigrations:
    async def test_migrated_schema_matches_the_models(self, db_url):
        db = Database(db_url)
        await db.migrate()
        await db.migrate()

        def diff(connection):
            return compare_metadata(MigrationContext.configure(connection), Base.metadata)

        async with db.write_engine.connect() as conn:
            changes = await conn.run_sync(diff)
        await db.dispose()
        assert changes == []
