"""A change the mission-state facility acknowledged as durable survives a real SIGKILL."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from behaviours.persistence import MissionRecord, Persisted
from robotd.store import StateStore

RECORD = MissionRecord("laundry.mission", 1, {"request_id": None, "holding": "none"})

CHILD = textwrap.dedent("""
    import asyncio, sys
    from behaviours.persistence import MissionRecord, Persisted
    from robotd.store import StateStore

    RECORD = MissionRecord("laundry.mission", 1, {"request_id": None, "holding": "none"})

    async def main() -> None:
        store = StateStore(sys.argv[1])
        writer = asyncio.create_task(store.run(lambda: None))
        kept = Persisted(store, RECORD)
        i = 0
        while True:
            i += 1
            kept.set(holding="dirty" if i % 2 else "clean")  # left to the writer task
            await kept.update(request_id=i)
            print("ACK", i, flush=True)  # acknowledged: durable from here on

    asyncio.run(main())
""")


class TestSigkill:
    def test_the_last_acknowledged_change_is_on_disk_after_sigkill(self, tmp_path: Path) -> None:
        """Killed while it writes as fast as it can: the store opens cleanly and holds the last
        acknowledged request id or a later one, never an earlier one."""
        path = tmp_path / "state.sqlite3"
        child = subprocess.Popen([sys.executable, "-c", CHILD, str(path)],
                                 stdout=subprocess.PIPE, text=True)
        assert child.stdout is not None
        acknowledged = 0
        try:
            for line in child.stdout:
                if not line.startswith("ACK "):
                    continue  # a log line
                acknowledged = int(line.split()[1])
                if acknowledged >= 40:
                    break
            child.send_signal(signal.SIGKILL)
        finally:
            child.kill()
            child.wait()
        store = StateStore(path)
        kept = Persisted(store, RECORD)
        store.close()
        assert kept.restored
        assert kept["request_id"] >= acknowledged
        assert kept["request_id"] <= acknowledged + 1
