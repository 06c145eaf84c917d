"""One control connection: its subscriptions, a bounded queue of lines, what it has been doing."""

from __future__ import annotations

import asyncio
from collections import deque

import structlog

from robotd.control.lines import WorkBudget
from robotd.control.rpc import notification_line

log = structlog.get_logger(__name__)


class Client:
    """One connection: its subscriptions, a bounded queue of lines to send, its activity."""

    def __init__(self, client_id: int, writer: asyncio.StreamWriter, queue_limit: int,
                 now_s: float, budget: WorkBudget) -> None:
        self.id = client_id
        self.topics: set[str] = set()
        self._writer = writer
        self._queue: deque[bytes] = deque()
        self._limit = queue_limit
        self._wake = asyncio.Event()
        self._room = asyncio.Event()
        self._room.set()
        self.dropped = 0
        self.dropped_total = 0
        self.closed = False
        self.last_request_s = now_s
        self.writing_since_s: float | None = None
        """Loop time since which its replies wait for it to read them (None: they drained)."""
        self.budget = budget

    def send_reply(self, line: bytes) -> bool:
        """Queue a reply; False (and the client is closed) when it stopped reading."""
        if len(self._queue) >= self._limit:
            log.warning("control.client_stuck", client=self.id, queued=len(self._queue))
            self.close()
            return False
        self._queue.append(line)
        self._wake.set()
        if len(self._queue) >= self._limit:
            self._room.clear()
        return True

    async def room_for_replies(self) -> None:
        """Wait while its queue is full: a client is not read faster than it reads its
        replies (one that stops reading is evicted as stalled, not here)."""
        await self._room.wait()

    def send_notification(self, line: bytes) -> None:
        """Queue a notification, or count it lost when the client is behind."""
        if len(self._queue) >= self._limit:
            self.dropped += 1
            self.dropped_total += 1
            return
        self._queue.append(line)
        self._wake.set()

    def take_queued(self) -> list[bytes]:
        """The lines queued and not yet written (they are the caller's to send now)."""
        lines = list(self._queue)
        self._queue.clear()
        return lines

    async def write_loop(self) -> None:
        loop = asyncio.get_running_loop()
        while not self.closed:
            await self._wake.wait()
            self._wake.clear()
            if self.dropped:
                notice = notification_line("dropped", {"count": self.dropped,
                                                       "reason": "client fell behind"})
                self.dropped = 0
                self._writer.write(notice)
            while self._queue:
                self._writer.write(self._queue.popleft())
            self._room.set()
            self.writing_since_s = loop.time()
            await self._writer.drain()
            self.writing_since_s = None

    @property
    def gone(self) -> bool:
        """Whether the connection is lost (its lines read but not yet served are moot)."""
        return self._writer.transport.is_closing()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._wake.set()
            self._room.set()
            self._writer.close()

    def close_saying(self, line: bytes) -> None:
        """Close after one last line saying why; at once when it does not read (the line
        could never reach it, and its unread replies would hold the socket open)."""
        if self.closed:
            return
        self.closed = True
        self._queue.clear()
        self._wake.set()
        self._room.set()
        if self.writing_since_s is not None:
            self._writer.transport.abort()
            return
        self._writer.write(line)
        self._writer.close()  # the transport sends what it holds, then closes


async def close_cleanly(reader: asyncio.StreamReader, writer: asyncio.StreamWriter,
                        lines: list[bytes], linger_s: float) -> None:
    """Send the last lines and close cleanly: end our side, then read and drop what the
    client still sends for up to ``linger_s``, so that its request meets no closed socket
    (``Broken pipe``) before it has read why."""
    for line in lines:
        writer.write(line)
    try:
        if writer.can_write_eof():
            writer.write_eof()
        async with asyncio.timeout(linger_s):
            while await reader.read(64 * 1024):
                pass
    except (TimeoutError, ConnectionError, OSError):
        pass
    finally:
        writer.close()
