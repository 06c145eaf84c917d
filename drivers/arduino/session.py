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
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

import structlog

from drivers.arduino.config import LinkConfig
from drivers.arduino.events import (
    REPLY_BYTES,
    Event,
    Evidence,
    Preempted,
    rank,
    worth_fast_resend,
)
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

# A well-formed command the MCU refuses (NAK:PARSE/RANGE) is sent again this often at most.
MAX_REFUSAL_RESENDS = 2


@dataclass(slots=True)
class InFlight:
    """The command on the line, and how its exchange has gone so far."""

    command: Command
    seq: int | None
    frame: bytes
    first_s: float  # first transmission
    last_s: float  # latest transmission
    timeouts: int = 0
    fast: int = 0  # resends on evidence, before the timeout
    refusals: int = 0


class Session:
    """Serves one open port until it breaks; ``broken`` then holds why (LinkBroken, OSError)."""

    def __init__(self, streams: StreamPair, config: LinkConfig, outbox: Outbox,
                 counters: LinkCounters, on_telemetry: Callable[[Telemetry, float], None],
                 next_seq: int) -> None:
        self.reader, self.writer = streams
        self.config = config
        self.framing = config.framing
        self.outbox = outbox
        self.counters = counters
        self.on_telemetry = on_telemetry  # each telemetry line, with the loop time it came
        self.next_seq = next_seq
        self.inflight: InFlight | None = None
        self._events: list[Event] = []
        self._decide_due = False  # _decide is scheduled
        self._pump_due = False  # _pump is scheduled
        self._closed = False
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
        self.outbox.on_put = self._on_put
        self._on_put()  # what was queued before this connection

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
        self._closed = True
        if self.outbox.on_put == self._on_put:
            self.outbox.on_put = None
        if self._deadline_timer is not None:
            self._deadline_timer.cancel()
            self._deadline_timer = None
        inflight, self.inflight = self.inflight, None
        if inflight is not None:  # nobody can tell whether it ran
            inflight.command.settle(Outcome.LINK_DOWN, seq=inflight.seq,
                                    resends=inflight.timeouts + inflight.fast,
                                    detail="link went down in flight")
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
        if isinstance(line, Telemetry):  # most lines: looked at first
            self.last_rx_s = now = self._loop.time()
            if self.inflight is not None:
                self._post(Evidence(definite=line.name == "BOOT", intact=True))
            self.on_telemetry(line, now)
            return
        if isinstance(line, Garbled):
            self.counters.crc_errors += 1
            log.debug("link.garbled", reason=line.reason, raw=line.raw)
            self._post(Evidence(definite=False))
            return
        self.last_rx_s = self._loop.time()
        if isinstance(line, Unparsed):
            self.counters.unparsed += 1
            log.info("link.unparsed", reason=line.reason, raw=line.raw)
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
            self._decide_soon()

    def _decide_soon(self) -> None:
        if not self._decide_due:
            self._decide_due = True
            self._loop.call_soon(self._decide)

    # -- sending -----------------------------------------------------------------------------
    # The sender is driven by callbacks, not a task: the outbox (a command was queued), the
    # receiver (a reply or evidence arrived) and one deadline timer each schedule the next
    # step with call_soon, where a task would have been woken, so steps run in the same
    # order as a task's would; no coroutine is resumed for the twenty-odd commands a second.
    # Frames are at most 64 bytes with one in flight, so no writer drain is ever due.
    def _on_put(self) -> None:
        """A command was queued: send it on the loop's next step if the line is free."""
        if self.inflight is None and not self._pump_due and not self._closed:
            self._pump_due = True
            self._loop.call_soon(self._pump)

    def _pump(self) -> None:
        """Send the most urgent queued command while none is in flight."""
        self._pump_due = False
        try:
            while self.inflight is None and not self._closed:
                command = self.outbox.pop()
                if command is None:
                    return
                self._begin(command)
        except Exception as exc:  # a sender bug: give the connection up, as a task would
            self._connection_ended(exc)

    def _take_seq(self) -> int | None:
        if self.framing is Framing.PLAIN:
            return None
        seq = self.next_seq
        self.next_seq = (seq + 1) % SEQ_MODULO
        return seq

    def _transmit(self, frame: bytes, kind: Kind) -> None:
        self.writer.write(frame)
        if kind is Kind.MOTOR or kind is Kind.HEARTBEAT:
            self.last_drive_tx_s = self._loop.time()

    def _begin(self, command: Command) -> None:
        seq = self._take_seq()
        try:
            frame = encode_command(command.payload, seq, self.framing)
        except ValueError as exc:
            command.settle(Outcome.NAK, seq=seq, detail=str(exc))
            return
        now = self._loop.time()
        self._events.clear()
        self.inflight = InFlight(command, seq, frame, now, now)
        self._transmit(frame, command.kind)
        self.counters.sent += 1
        self._wake_at(now + self.config.ack_timeout_s)

    def _decide(self) -> None:
        """Act on what came in for the frame in flight (or on its reply being overdue)."""
        self._decide_due = False
        try:
            while (inflight := self.inflight) is not None and self._decide_once(inflight):
                pass
        except Exception as exc:  # a sender bug: give the connection up, as a task would
            self._connection_ended(exc)

    def _decide_once(self, inflight: InFlight) -> bool:
        """One event's worth; True when the next event is to be looked at at once."""
        event = self._next_event(inflight.last_s + self.config.ack_timeout_s)
        if event is False:
            return False  # nothing yet: the deadline timer or the next line calls again
        command, seq = inflight.command, inflight.seq
        now = self._loop.time()
        resends = inflight.timeouts + inflight.fast
        if isinstance(event, Ack | Hello):
            self._acked(inflight, event, resends, now - inflight.first_s)
            self._finish()
            return False
        if isinstance(event, Nak) and event.reason != "CRC" and (
                inflight.refusals >= MAX_REFUSAL_RESENDS or not well_formed(command.payload)
                or self.framing is Framing.PLAIN):
            command.settle(Outcome.NAK, seq=seq, resends=resends, detail=f"NAK:{event.reason}")
            log.warning("link.nak", seq=seq, payload=command.payload, reason=event.reason)
            self._finish()
            return False
        if isinstance(event, Preempted):
            self.counters.superseded += 1
            command.settle(Outcome.SUPERSEDED, seq=seq, resends=resends,
                           detail="preempted by STOP")
            self._finish()
            return False
        if isinstance(event, Nak) and event.reason != "CRC":
            inflight.refusals += 1  # a valid command refused: damage the CRC did not catch
            inflight.fast += 1
        elif event is None:
            if inflight.timeouts >= self.config.max_resends or now - inflight.first_s >= (
                    self.config.give_up_s - 1e-9):
                self._lost(inflight, resends)
                self._finish()
                return False
            inflight.timeouts += 1
        elif self.framing is Framing.PLAIN or not worth_fast_resend(
                event, fast=inflight.fast, since_last_s=now - inflight.last_s,
                since_first_s=now - inflight.first_s, give_up_s=self.config.give_up_s,
                reply_due_s=(len(inflight.frame) + REPLY_BYTES) * self._byte_s,
                recent_rtt_s=min(self._recent_rtt_s) if self._recent_rtt_s else 0.0):
            return True  # tells nothing yet: look again (the reply may be overdue by now)
        else:
            inflight.fast += 1
        self._transmit(inflight.frame, command.kind)
        self.counters.resent += 1
        inflight.last_s = self._loop.time()
        log.debug("link.resent", seq=seq, payload=command.payload,
                  timeouts=inflight.timeouts, fast=inflight.fast)
        self._wake_at(inflight.last_s + self.config.ack_timeout_s)
        return False

    def _finish(self) -> None:
        """The frame in flight is done with: on to the next queued command at once."""
        self.inflight = None
        self._pump()

    def _next_event(self, deadline_s: float) -> Event | Literal[False] | None:
        """The most telling event (ACK beats NAK beats the rest); None when ``deadline_s``
        passed with none; False when there is none yet."""
        if not self._events:
            return None if deadline_s - self._loop.time() <= CLOCK_SLACK_S else False
        events, self._events = self._events, []
        if len(events) > 1:
            events.sort(key=rank)
        return events[0]

    def _wake_at(self, deadline_s: float) -> None:
        """Decide again at ``deadline_s`` (the timer already set fires first, moves on).

        One deadline timer for the session that moves itself on, instead of a timer set
        and cancelled for each of twenty commands a second."""
        self._deadline_s = deadline_s
        timer = self._deadline_timer
        if timer is not None:
            if timer.when() <= deadline_s:
                return
            timer.cancel()
        self._deadline_timer = self._loop.call_at(deadline_s, self._deadline_passed)

    def _deadline_passed(self) -> None:
        timer, self._deadline_timer = self._deadline_timer, None
        if self.inflight is None or timer is None:
            return
        if self._deadline_s > timer.when():  # a later deadline was set meanwhile
            self._deadline_timer = self._loop.call_at(self._deadline_s, self._deadline_passed)
            return
        self._decide_soon()

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
