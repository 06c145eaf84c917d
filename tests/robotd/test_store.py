"""The state store: JSON values by key in SQLite WAL, restored after a restart."""

from __future__ import annotations

import asyncio
import sqlite3
from pathlib import Path

import pytest

from robotd.store import StateStore


class TestStateStore:
    def test_values_survive_a_restart(self, tmp_path: Path) -> None:
        """What was put (and flushed by close) is there when the store is opened again."""
        store = StateStore(tmp_path / "state.sqlite3")
        store.put("laundry.request", {"id": 7, "loaded": True})
        store.put("pose", [1.5, -0.25, 3.14])
        store.delete("pose")
        store.close()
        again = StateStore(tmp_path / "state.sqlite3")
        assert again.get("laundry.request") == {"id": 7, "loaded": True}
        assert again.get("pose", "gone") == "gone"
        again.close()

    def test_the_writer_task_makes_values_durable_without_close(self, tmp_path: Path) -> None:
        """The running writer commits puts; another connection sees them (WAL mode)."""
        path = tmp_path / "state.sqlite3"

        async def main() -> None:
            store = StateStore(path)
            task = asyncio.create_task(store.run(lambda: None))
            store.put("holds", "parcel")
            for _ in range(100):
                await asyncio.sleep(0.01)
                rows = sqlite3.connect(path).execute("SELECT value FROM kv").fetchall()
                if rows:
                    break
            assert rows == [('"parcel"',)]
            task.cancel()
            await store.aclose()

        asyncio.run(main())
        mode = sqlite3.connect(path).execute("PRAGMA journal_mode").fetchone()
        assert mode == ("wal",)

    def test_a_value_json_cannot_hold_is_refused_with_its_key(self, tmp_path: Path) -> None:
        store = StateStore(tmp_path / "s.sqlite3")
        with pytest.raises(ValueError, match="store: when: value is not JSON-able"):
            store.put("when", object())
        store.close()
