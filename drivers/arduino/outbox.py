"""The link's outgoing command queue: STOP first, one MOTOR slot, bounded cosmetic commands.

``STOP`` and ``MOTOR`` are critical and never dropped: a newer ``MOTOR`` replaces a queued
older one (the wheels only care about the newest), ``STOP`` replaces every queued ``MOTOR``
and heartbeat. LED, servo and scan commands wait in order; past the limit the oldest is
dropped and counted. Every command ends with exactly one ``Delivery``, never an exception.
"""

from __future__ import annotations

import asyncio
import collections
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, IntEnum


class Kind(IntEnum):
    """Send priority, lowest value first."""

    STOP = 0
    HELLO = 1
    MOTOR = 2
    HEARTBEAT = 3
    NORMAL = 4


class Outcome(Enum):
    ACKED = "acked"
    SUPERSEDED = "superseded"  # replaced in the queue, or preempted in flight by STOP
    DROPPED = "dropped"  # queue overflow
    LOST = "lost"  # no acknowledgement after every resend
    NAK = "nak"  # the MCU refused it (PARSE or RANGE)
    LINK_DOWN = "link_down"  # the port went away before it was acknowledged


@dataclass(frozen=True, slots=True)
class Delivery:
    """How one command ended. ``rtt_s`` only for first-try acknowledgements (Karn)."""

    payload: str
    outcome: Outcome
    seq: int | None = None
    resends: int = 0
    rtt_s: float | None = None
    detail: str = ""

    @property
    def ok(self) -> bool:
        return self.outcome is Outcome.ACKED


def kind_of(payload: str) -> Kind:
    if payload == "STOP":
        return Kind.STOP
    if payload == "HELLO":
        return Kind.HELLO
    if payload.startswith("MOTOR:"):
        return Kind.MOTOR
    if payload == "HB":
        return Kind.HEARTBEAT
    return Kind.NORMAL


class Command:
    """One command on its way: payload, priority and the future its sender may await.

    ``future`` None: nobody waits for how it ends (wheel commands and heartbeats, twenty or
    more a second), so no Delivery is made for it.
    """

    __slots__ = ("future", "kind", "payload")

    def __init__(self, payload: str, future: asyncio.Future[Delivery] | None) -> None:
        self.payload = payload
        self.kind = kind_of(payload)
        self.future = future

    def settle(self, outcome: Outcome, **details: object) -> None:
        if self.future is not None and not self.future.done():
            self.future.set_result(Delivery(self.payload, outcome, **details))  # type: ignore[arg-type]


class Outbox:
    """Commands waiting to be sent; ``pop()`` hands out the most urgent one, and ``on_put``
    tells the sender when there is one."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.dropped = 0
        self.superseded = 0
        self._stop: Command | None = None
        self._hello: Command | None = None
        self._motor: Command | None = None
        self._heartbeat: Command | None = None
        self._normal: collections.deque[Command] = collections.deque()
        self.on_put: Callable[[], None] | None = None  # told after each put (the sender)

    def __len__(self) -> int:
        slots = (self._stop, self._hello, self._motor, self._heartbeat)
        return sum(s is not None for s in slots) + len(self._normal)

    def put(self, command: Command) -> None:
        kind = command.kind
        if kind is Kind.STOP:
            for old in (self._stop, self._motor, self._heartbeat):
                self._supersede(old, "replaced by STOP")
            self._stop, self._motor, self._heartbeat = command, None, None
        elif kind is Kind.HELLO:
            self._supersede(self._hello, "replaced by a newer HELLO")
            self._hello = command
        elif kind is Kind.MOTOR:
            if self._motor is not None:  # twenty a second: usually sent already
                self._supersede(self._motor, "replaced by a newer MOTOR")
            if self._heartbeat is not None:
                self._supersede(self._heartbeat, "a MOTOR feeds the deadman too")
            self._motor, self._heartbeat = command, None
        elif kind is Kind.HEARTBEAT:
            if self._motor is not None or self._heartbeat is not None:
                command.settle(Outcome.SUPERSEDED, detail="a MOTOR or HB is already queued")
                return
            self._heartbeat = command
        else:
            self._normal.append(command)
            while len(self._normal) > self.limit:
                self._normal.popleft().settle(Outcome.DROPPED, detail="queue full")
                self.dropped += 1
        if self.on_put is not None:
            self.on_put()

    def _supersede(self, old: Command | None, detail: str) -> None:
        if old is not None:
            self.superseded += 1
            old.settle(Outcome.SUPERSEDED, detail=detail)

    def has(self, kind: Kind) -> bool:
        if kind is Kind.NORMAL:
            return bool(self._normal)
        if kind is Kind.MOTOR:
            return self._motor is not None
        if kind is Kind.HEARTBEAT:
            return self._heartbeat is not None
        if kind is Kind.STOP:
            return self._stop is not None
        return self._hello is not None

    def pop(self) -> Command | None:
        """The most urgent command, or None when empty."""
        command = self._stop
        if command is not None:
            self._stop = None
            return command
        command = self._hello
        if command is not None:
            self._hello = None
            return command
        command = self._motor
        if command is not None:
            self._motor = None
            return command
        command = self._heartbeat
        if command is not None:
            self._heartbeat = None
            return command
        if self._normal:
            return self._normal.popleft()
        return None

    def clear(self, outcome: Outcome, detail: str = "") -> None:
        """Settle every queued command with ``outcome`` (the link went down)."""
        while (command := self.pop()) is not None:
            command.settle(outcome, detail=detail)
