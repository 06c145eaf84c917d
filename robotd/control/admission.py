"""Who may hold a control connection: the limits, which client gives way, which is overdue.

Nothing may lock a technician out of the e-stop (issue 28): idle connections are closed after
``idle_timeout_s``, a client whose replies stopped draining after ``stall_timeout_s``, and when
the socket is full the client idle longest gives its place to a newcomer. When no one can give
way, newcomers wait for a place (``overflow``); an ``estop`` is served past the limit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol


@dataclass(frozen=True, slots=True)
class ClientPolicy:
    """How long a connection may sit idle or stalled, and what happens past the limit.

    Args:
        wait_max: connections past ``max_clients`` that wait up to ``wait_s`` for a place
            (the waiting room); an ``estop`` among them is served at once.
        wait_s: time a connection in the waiting room has to send its first request and get
            a place; a connection to the e-stop socket, to send its ``estop``.
        idle_timeout_s: a connection that sends no request for this long is closed; one that
            subscribed is never idle while it reads.
        stall_timeout_s: a connection whose replies have not drained for this long (it stopped
            reading) is closed.
        evict_idle_s: when the socket is full, a connection idle (or stalled) for this long
            gives its place to a newcomer.
        lines_per_s: work units (a request or a refused line is one; 256 blank lines are one)
            a client may spend per second once its ``lines_burst`` is spent; it is read no
            faster than that.
        lines_burst: work units a client may spend at once.
        refusal_linger_s: a refused connection's first line is waited for this long (an
            ``estop`` is served even then; anything else is refused with its id), and what it
            sends after the refusal is read and dropped for as long, so that its request does
            not meet a closed socket (``Broken pipe``) before it can read why.
        lingering_max: refused connections treated so at once; past that they are told and
            closed at once (a connect storm must not run the daemon out of file descriptors).
        estop_socket_max: connections to the e-stop socket served at once.
    """

    wait_max: int = 128
    wait_s: float = 1.0
    idle_timeout_s: float = 60.0
    stall_timeout_s: float = 10.0
    evict_idle_s: float = 1.0
    lines_per_s: float = 4096.0
    lines_burst: float = 4096.0
    refusal_linger_s: float = 0.5
    lingering_max: int = 64
    estop_socket_max: int = 16

    @classmethod
    def from_settings(cls, get: Callable[[str], Any]) -> ClientPolicy:
        """The policy the ``[control]`` keys set (``get`` reads one, e.g. ``Settings.get``)."""
        return cls(**{name: get(f"control.{name}") for name in _CONFIGURED})

    @property
    def reap_every_s(self) -> float:
        """How often idle and stalled connections are looked for."""
        return min(1.0, max(0.01, min(self.idle_timeout_s, self.stall_timeout_s) / 4))


_CONFIGURED = ("wait_max", "wait_s", "idle_timeout_s", "stall_timeout_s", "evict_idle_s",
               "lines_per_s", "lines_burst")


class Activity(Protocol):
    """What the policy reads of a connection."""

    @property
    def id(self) -> int: ...

    @property
    def topics(self) -> set[str]: ...

    @property
    def last_request_s(self) -> float: ...

    @property
    def writing_since_s(self) -> float | None: ...


def idle_s(client: Activity, now_s: float) -> float:
    """Seconds since the client's last request (or its connection); 0 for a reading
    subscriber, which is not idle."""
    if client.topics:
        return 0.0
    return now_s - client.last_request_s


def stalled_s(client: Activity, now_s: float) -> float:
    """Seconds its replies have waited for it to read them (0 when they drain)."""
    since = client.writing_since_s
    return 0.0 if since is None else now_s - since


def overdue(clients: Iterable[Activity], now_s: float, policy: ClientPolicy
            ) -> list[tuple[Activity, str, float]]:
    """The connections to close now: ``(client, "stalled" | "idle", seconds)``."""
    out: list[tuple[Activity, str, float]] = []
    for client in clients:
        stalled = stalled_s(client, now_s)
        if stalled >= policy.stall_timeout_s:
            out.append((client, "stalled", stalled))
            continue
        idle = idle_s(client, now_s)
        if idle >= policy.idle_timeout_s:
            out.append((client, "idle", idle))
    return out


def give_way(clients: Iterable[Activity], now_s: float, policy: ClientPolicy
             ) -> tuple[Activity, str, float] | None:
    """When the socket is full: the client that gives its place to a newcomer (the one idle
    or stalled longest, at least ``evict_idle_s``), or None when every one is busy."""
    best: tuple[Activity, str, float] | None = None
    for client in clients:
        stalled = stalled_s(client, now_s)
        reason, seconds = ("stalled", stalled) if stalled else ("idle", idle_s(client, now_s))
        if seconds >= policy.evict_idle_s and (best is None or seconds > best[2]):
            best = (client, reason, seconds)
    return best
