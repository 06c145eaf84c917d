"""The daemon's state as its control socket publishes it, for the script's ``when_state``."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable
from pathlib import Path

import structlog

log = structlog.get_logger(__name__)

RETRY_S = 0.2


class StateWatch:
    """Follows ``state`` notifications on the socket at ``path`` (reconnecting when it goes);
    ``state`` is the latest, and ``on_change`` is called on each transition."""

    def __init__(self, path: Path, on_change: Callable[[], None]) -> None:
        self.path = path
        self.state = ""
        self.on_change = on_change

    async def run(self) -> None:
        while True:
            try:
                await self._follow()
            except (OSError, ValueError, asyncio.IncompleteReadError) as exc:
                log.debug("feed.state_watch_retry", error=str(exc))
            await asyncio.sleep(RETRY_S)

    async def _follow(self) -> None:
        reader, writer = await asyncio.open_unix_connection(str(self.path), limit=1 << 22)
        try:
            for i, (method, params) in enumerate((("status", {}),
                                                  ("subscribe", {"topics": ["state"]}))):
                request = {"jsonrpc": "2.0", "id": i + 1, "method": method, "params": params}
                writer.write(json.dumps(request).encode() + b"\n")
            await writer.drain()
            while line := await reader.readline():
                message = json.loads(line)
                result = message.get("result")
                if message.get("id") == 1 and isinstance(result, dict):
                    self._set(str(result.get("state", "")))
                elif message.get("method") == "state":
                    self._set(str(message.get("params", {}).get("dst", "")))
        finally:
            writer.close()

    def _set(self, state: str) -> None:
        if state and state != self.state:
            self.state = state
            self.on_change()
