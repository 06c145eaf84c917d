"""One open connection to the motor board: receiver, one-in-flight sender, heartbeat, watchdog.

The sender transmits one command at a time and waits for its acknowledgement. It resends the
same frame (same SEQ) when ``ack_timeout_s`` passes in silence, at most ``max_resends`` times;
it also resends at once when the line shows the frame was damaged (``NAK:CRC``, or a garbled
line arriving after the reply was due), within ``give_up_s`` of the first transmission. The MCU
drops duplicates of its last SEQ, so resends never execute twice. Plain framing has no SEQ
and no duplicate check, so it resends only on timeout (an old sketch may run it twice).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar

import structlog

from drivers.arduino.config import LinkConfig
from drivers.arduino.framing import (
    SEQ_MODULO,
    Ack,
    Framing,
    Garbled,
    Hello,
    Line,
    Nak,
    Telemetry,
    Unparsed,
    encode_command,
    well_formed,
)
from drivers.arduino.keepalive import CLOCK_SLACK_S, send_heartbeats, watch_silence
from drivers.arduino.outbox import Command, Kind, Outbox, Outcome
from drivers.arduino.receiver import LineReceiver, LinkBroken
from drivers.arduino.stats import LinkCounters
from hal.ports import StreamPair

log = structlog.get_logger(__name__)

T = TypeVar("T")

# Fast resends per command are also bounded by count, so a line that garbles everything
# cannot make the sender spin when the wire takes no time (the in-memory pipe).
MAX_FAST_RESENDS = 32
# A well-formed command the MCU refuses (NAK:PARSE/RANGE) is sent again this often at most.
MAX_REFUSAL_RESENDS = 2
# Slack for USB serial adapters that hold bytes back before passing them on (FTDI: 16 ms).
USB_LATENCY_S = 0.02
# Bytes of the longest reply (``#255 NAK:PARSE*CC\n``), to know when a reply is due.
REPLY_BYTES = 18


class Preempted:
    """Mailbox marker: STOP wants the line now."""


class Evidence(NamedTuple):
    """Mailbox marker: our frame may be lost (garbled line, NAK:CRC, reboot, later telemetry).

    ``definite``: resend at once. ``intact``: an intact telemetry line, which tells only once
    the reply is overdue, since the MCU answers a frame before it sends further telemetry.
    """

    definite: bool = False
    intact: bool = False


Event = Ack | Hello | Nak | Preempted | Evidence


class InFlight(NamedTuple):
    command: Command
    seq: int | None
    frame: bytes


class Session:
    """Serves one open port until it breaks; ``run()`` raises LinkBroken or OSError then."""

    def __init__(self, streams: StreamPair, config: LinkConfig, outbox: Outbox,
                 counters: LinkCounters, on_telemetry: Callable[[Telemetry], None],
                 next_seq: int) -> None:
        self.reader, self.writer = streams
        self.config = config
        self.framing = config.framing
        self.outbox = outbox
        self.counters = counters
        self.on_telemetry = on_telemetry
        self.next_seq = next_seq
        self.inflight: InFlight | None = None
        self._events: list[Event] = []
        self._waiter: asyncio.Future[None] | None = None
        self._deadline_s = 0.0
        self._deadline_timer: asyncio.TimerHandle | None = None
        self._loop = asyncio.get_running_loop()
        self.last_rx_s = self._loop.time()
        self.last_drive_tx_s = self._loop.time()
        self._byte_s = 10.0 / config.baud  # 8N1: ten bit times a byte
        self._recent_rtt_s: collections.deque[float] = collections.deque(maxlen=4)
        self._tasks: list[asyncio.Task[None]] = []
        self.broken: asyncio.Future[BaseException] = self._loop.create_future()
        self.receiver = LineReceiver(self.framing, counters, self._on_line,
                                     self._connection_ended)

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self) -> None:
        if not self.receiver.attach((self.reader, self.writer)):
            self._spawn(self.receiver.pump(self.reader))
        self._spawn(self._send_loop())

    def start_keepalive(self) -> None:
        """Heartbeat and silence watchdog; only crc firmware answers HB."""
        if self.framing is Framing.CRC:
            self._spawn(send_heartbeats(self))
            self._spawn(watch_silence(self))

    def _spawn(self, coro: object) -> None:
        task: asyncio.Task[None] = self._loop.create_task(coro)  # type: ignore[arg-type]
        task.add_done_callback(self._task_done)
        self._tasks.append(task)

    def _task_done(self, task: asyncio.Task[None]) -> None:
        if task.cancelled() or self.broken.done():
            return
        exc = task.exception() or LinkBroken("a link task ended")
        self.broken.set_result(exc)

    def _connection_ended(self, exc: BaseException) -> None:
        """The port's connection ended, or a received line failed."""
        if not self.broken.done():
            self.broken.set_result(exc)

    async def wait_broken(self) -> BaseException:
        return await asyncio.shield(self.broken)

    async def close(self) -> None:
        if self._deadline_timer is not None:
            self._deadline_timer.cancel()
            self._deadline_timer = None
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        self.writer.close()
        with contextlib.suppress(OSError, TimeoutError):
            await asyncio.wait_for(self.writer.wait_closed(), timeout=1.0)

    async def race(self, future: asyncio.Future[T]) -> T:
        """Await ``future`` unless the connection breaks first (then raise LinkBroken)."""
        waiters: set[asyncio.Future[Any]] = {future, self.broken}
        done, _ = await asyncio.wait(waiters, return_when=asyncio.FIRST_COMPLETED)
        if future in done:
            return future.result()
        msg = f"connection broke: {self.broken.result()}"
        raise LinkBroken(msg)

    def preempt(self) -> None:
        """STOP was queued: give up waiting for the command in flight (unless it is a STOP)."""
        if self.inflight is not None and self.inflight.command.kind is not Kind.STOP:
            self._post(Preempted())

    # -- receiving ---------------------------------------------------------------------------
    def _on_line(self, line: Line) -> None:
        if isinstance(line, Garbled):
            self.counters.crc_errors += 1
            log.debug("link.garbled", reason=line.reason, raw=line.raw)
            self._post(Evidence(definite=False))
            return
        self.last_rx_s = self._loop.time()
        if isinstance(line, Unparsed):
            self.counters.unparsed += 1
            log.info("link.unparsed", reason=line.reason, raw=line.raw)
        elif isinstance(line, Telemetry):
            if self.inflight is not None:
                self._post(Evidence(definite=line.name == "BOOT", intact=True))
            self.on_telemetry(line)
        else:
            self._on_reply(line)

    def _on_reply(self, reply: Ack | Hello | Nak) -> None:
        if isinstance(reply, Nak):
            self.counters.nak += 1
        inflight = self.inflight
        if inflight is not None and reply.seq == inflight.seq:
            self._post(reply)
        elif isinstance(reply, Nak) and reply.reason == "CRC":
            self._post(Evidence(definite=True))  # our frame, its SEQ digits damaged
        else:
            self.counters.stale_replies += 1

    def _post(self, event: Event) -> None:
        if self.inflight is not None:
            self._events.append(event)
            if self._waiter is not None:
                _wake(self._waiter)

    # -- sending -----------------------------------------------------------------------------
    async def _send_loop(self) -> None:
        while True:
            command = await self.outbox.get()
            await self._exchange(command)

    def _take_seq(self) -> int | None:
        if self.framing is Framing.PLAIN:
            return None
        seq = self.next_seq
        self.next_seq = (seq + 1) % SEQ_MODULO
        return seq

    def _transmit(self, frame: bytes, kind: Kind) -> bool:
        """Write ``frame``; True when the port holds bytes back (then drain the writer)."""
        self.writer.write(frame)
        if kind is Kind.MOTOR or kind is Kind.HEARTBEAT:
            self.last_drive_tx_s = self._loop.time()
        return self.writer.transport.get_write_buffer_size() > 0

    async def _exchange(self, command: Command) -> None:
        seq = self._take_seq()
        try:
            frame = encode_command(command.payload, seq, self.framing)
        except ValueError as exc:
            command.settle(Outcome.NAK, seq=seq, detail=str(exc))
            return
        inflight = InFlight(command, seq, frame)
        self._events.clear()
        self.inflight = inflight
        first_s = last_s = self._loop.time()
        if self._transmit(frame, command.kind):
            await self.writer.drain()
        self.counters.sent += 1
        timeouts = fast = refusals = 0
        try:
            while True:
                event = await self._next_event(last_s + self.config.ack_timeout_s)
                now = self._loop.time()
                if isinstance(event, Ack | Hello):
                    self._acked(inflight, event, timeouts + fast, now - first_s)
                    return
                if isinstance(event, Nak) and event.reason != "CRC" and (
                        refusals >= MAX_REFUSAL_RESENDS or not well_formed(command.payload)
                        or self.framing is Framing.PLAIN):
                    command.settle(Outcome.NAK, seq=seq, resends=timeouts + fast,
                                   detail=f"NAK:{event.reason}")
                    log.warning("link.nak", seq=seq, payload=command.payload,
                                reason=event.reason)
                    return
                if isinstance(event, Preempted):
                    self.counters.superseded += 1
                    command.settle(Outcome.SUPERSEDED, seq=seq, resends=timeouts + fast,
                                   detail="preempted by STOP")
                    return
                if isinstance(event, Nak) and event.reason != "CRC":
                    refusals += 1  # a valid command refused: damage the CRC did not catch
                    fast += 1
                elif event is None:
                    if timeouts >= self.config.max_resends or now - first_s >= (
                            self.config.give_up_s - 1e-9):
                        self._lost(inflight, timeouts + fast)
                        return
                    timeouts += 1
                elif not self._worth_fast_resend(event, fast, now - last_s, now - first_s,
                                                 len(frame)):
                    continue
                else:
                    fast += 1
                if self._transmit(frame, command.kind):
                    await self.writer.drain()
                self.counters.resent += 1
                last_s = self._loop.time()
                log.debug("link.resent", seq=seq, payload=command.payload,
                          timeouts=timeouts, fast=fast)
        finally:
            self.inflight = None
            if command.future is not None:  # cancelled with the connection: did it run?
                command.settle(Outcome.LINK_DOWN, seq=seq, resends=timeouts + fast,
                               detail="link went down in flight")

    def _worth_fast_resend(self, event: Event, fast: int, since_last_s: float,
                           since_first_s: float, frame_bytes: int) -> bool:
        if self.framing is Framing.PLAIN or fast >= MAX_FAST_RESENDS:
            return False
        if since_first_s >= self.config.give_up_s:
            return False
        if isinstance(event, Nak) or (isinstance(event, Evidence) and event.definite):
            return True
        # Other lines only tell something once the reply to our frame was due.
        due_s = (frame_bytes + REPLY_BYTES) * self._byte_s
        if isinstance(event, Evidence) and event.intact:
            # Lines the MCU sent just before our frame reached it come one round trip later.
            recent_rtt_s = min(self._recent_rtt_s) if self._recent_rtt_s else 0.0
            due_s = max(due_s, recent_rtt_s) + USB_LATENCY_S
        return since_last_s >= due_s

    async def _next_event(self, deadline_s: float) -> Event | None:
        """The most telling event before ``deadline_s`` (ACK beats NAK beats the rest)."""
        while not self._events:
            if deadline_s - self._loop.time() <= CLOCK_SLACK_S:
                return None
            # A bare future (cheaper than wait_for: no extra task) and one deadline timer for
            # the session that moves itself on, instead of a timer set and cancelled for each
            # of twenty commands a second.
            waiter: asyncio.Future[None] = self._loop.create_future()
            self._waiter = waiter
            self._wake_at(deadline_s)
            try:
                await waiter
            finally:
                self._waiter = None
        events, self._events = self._events, []
        if len(events) > 1:
            events.sort(key=_rank)
        return events[0]

    def _wake_at(self, deadline_s: float) -> None:
        """Wake the waiter at ``deadline_s`` (the timer already set fires first, moves on)."""
        self._deadline_s = deadline_s
        timer = self._deadline_timer
        if timer is not None:
            if timer.when() <= deadline_s:
                return
            timer.cancel()
        self._deadline_timer = self._loop.call_at(deadline_s, self._deadline_passed)

    def _deadline_passed(self) -> None:
        timer, self._deadline_timer = self._deadline_timer, None
        if self._waiter is None or timer is None:
            return
        if self._deadline_s > timer.when():  # a later deadline was set meanwhile
            self._deadline_timer = self._loop.call_at(self._deadline_s, self._deadline_passed)
            return
        _wake(self._waiter)

    def _acked(self, inflight: InFlight, reply: Ack | Hello, resends: int,
               elapsed_s: float) -> None:
        self.counters.acked += 1
        self._recent_rtt_s.append(elapsed_s)  # an upper bound when resent; fine for a floor
        rtt_s = elapsed_s if resends == 0 else None
        if rtt_s is not None:
            self.counters.rtt_s.append(rtt_s)
        if inflight.command.future is not None:  # wheel commands and heartbeats: nobody waits
            detail = f"{reply.firmware},{reply.protocol}" if isinstance(reply, Hello) else ""
            inflight.command.settle(Outcome.ACKED, seq=inflight.seq, resends=resends,
                                    rtt_s=rtt_s, detail=detail)

    def _lost(self, inflight: InFlight, resends: int) -> None:
        self.counters.lost += 1
        inflight.command.settle(Outcome.LOST, seq=inflight.seq, resends=resends,
                                detail="no acknowledgement")
        log.warning("link.lost", seq=inflight.seq, payload=inflight.command.payload,
                    resends=resends)


def _wake(waiter: asyncio.Future[None]) -> None:
    if not waiter.done():
        waiter.set_result(None)


def _rank(event: Event) -> int:
    if isinstance(event, Ack | Hello):
        return 0
    if isinstance(event, Nak) and event.reason != "CRC":
        return 1
    if isinstance(event, Preempted):
        return 2
    return 3
