"""``robotctl watch``: one screen that fits the terminal, redrawn as soon as the robot changes.

It subscribes to the daemon's notifications (state, estop, service, link) and redraws when one
comes; the sensors' figures are read again every ``--interval`` seconds. The first lines hold
what a technician looks for first (state, estop, link), so an 80x24 terminal shows them.
"""

from __future__ import annotations

import shutil
import time
from collections import deque
from typing import Any, Protocol, TextIO

from robotd.ctl.connection import EXIT_CONNECT, EXIT_OK, CannotConnect

TOPICS = ["state", "estop", "service", "link"]
TRANSITIONS_SHOWN = 4


class WatchConnection(Protocol):
    path: str

    def call(self, method: str, params: dict[str, Any] | None = None) -> Any: ...
    def next_notification(self, timeout_s: float) -> dict[str, Any] | None: ...


class WatchScreen:
    """What the screen shows; ``lines(width, height)`` lays it out to fit."""

    def __init__(self) -> None:
        self.status: dict[str, Any] = {}
        self.sensors: dict[str, Any] = {}
        self.transitions: deque[dict[str, Any]] = deque(maxlen=TRANSITIONS_SHOWN)
        self.updated = ""

    def note(self, notification: dict[str, Any]) -> None:
        if notification.get("method") == "state":
            self.transitions.appendleft(notification.get("params", {}))

    def lines(self, width: int, height: int) -> list[str]:
        s = self.status
        lag = s.get("loop_lag_ms", {})
        head = [
            f"{s.get('robot', '?')} ({s.get('profile', '?')})  state {s.get('state', '?')}",
            f"estop {_estop(s)}",
            f"link {s.get('link') or '-'}   up {s.get('uptime_s', 0):.0f} s   loop lag p99 "
            f"{lag.get('p99_ms', 0):.1f} ms",
        ]
        services = [f"{v['name']}:{v['state']}"
                    + (f"({v['restarts']} restarts)" if v.get("restarts") else "")
                    for v in s.get("services", [])]
        tail = ["", "last transitions:"] + [
            f"  {t.get('t', 0):9.2f} s  {t.get('src')} -> {t.get('dst')}  ({t.get('trigger')})"
            for t in self.transitions] + [f"updated {self.updated}; Ctrl-C ends"]
        room = max(0, height - len(head) - len(tail) - 2)
        body = ["services: " + "  ".join(services) if services else "services: none"]
        body += ["sensors:"] + [f"  {line}" for line in _sensor_lines(self.sensors, width - 2)]
        lines = [*head, "", *_wrap_first(body, width)[:room], *tail]
        return [line[:width] for line in lines[:height]]


def watch(conn: WatchConnection, interval_s: float, out: TextIO) -> int:
    """Redraw on every notification and every ``interval_s``; 3 when the daemon goes away."""
    in_place = out.isatty()
    screen = WatchScreen()
    try:
        conn.call("subscribe", {"topics": TOPICS})
        for event in conn.call("events", {"limit": 100}):  # the story so far
            if event.get("kind") == "transition":
                screen.note({"method": "state", "params": event})
        next_sensors = 0.0
        while True:
            now = time.monotonic()
            screen.status = conn.call("status")
            if now >= next_sensors:
                screen.sensors = conn.call("sensors")
                next_sensors = now + interval_s
            screen.updated = time.strftime("%H:%M:%S")
            _draw(screen, out, in_place)
            notification = conn.next_notification(max(0.0, next_sensors - time.monotonic()))
            while notification is not None:
                screen.note(notification)
                notification = conn.next_notification(0.0)
    except KeyboardInterrupt:
        return EXIT_OK
    except CannotConnect as exc:
        out.write(f"\nrobotctl: robotd went away ({exc}); watch ends\n")
        out.flush()
        return EXIT_CONNECT


def _draw(screen: WatchScreen, out: TextIO, in_place: bool) -> None:
    size = shutil.get_terminal_size((80, 24))
    lines = screen.lines(size.columns, size.lines - 1 if in_place else 1000)
    if in_place:
        out.write("\x1b[H\x1b[2J")  # cursor home, clear screen
    else:
        out.write(f"--- {screen.updated}\n")
    out.write("\n".join(lines) + "\n")
    out.flush()


def _estop(s: dict[str, Any]) -> str:
    if not s.get("estop"):
        return "no"
    latch = s.get("estop_latch")
    if isinstance(latch, dict):
        return f"YES (latched by {latch.get('source')}: {latch.get('reason')!r})"
    return "YES"


def _sensor_lines(sensors: dict[str, Any], width: int) -> list[str]:
    """One line per device: its scalar figures as ``key=value``, as many as fit."""
    out = []
    for device, figures in sensors.get("devices", {}).items():
        parts = [f"{k}={_short(v)}" for k, v in figures.items() if not isinstance(v, dict | list)]
        line = f"{device}:"
        for part in parts:
            if len(line) + 1 + len(part) > width:
                break
            line += " " + part
        out.append(line)
    return out


def _wrap_first(lines: list[str], width: int) -> list[str]:
    """The services line wrapped to the width (it can be long); the rest as they are."""
    if not lines:
        return lines
    words, wrapped, current = lines[0].split("  "), [], ""
    for word in words:
        candidate = f"{current}  {word}" if current else word
        if len(candidate) > width and current:
            wrapped.append(current)
            current = "  " + word
        else:
            current = candidate
    wrapped.append(current)
    return wrapped + lines[1:]


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
