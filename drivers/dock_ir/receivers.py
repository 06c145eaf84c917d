"""``hal.devices.DockIr`` on demodulating IR receivers: edges -> codes -> what each one sees.

One task reads edge batches from the port and feeds each receiver's decoder; another, every
``publish_period_s``, closes frames whose gap has passed and publishes a ``DockIrReading``
with the codes each receiver decoded within the window (kobuki's OR over recent readings).
Bad signals never raise: they are counted per receiver (``status()``).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

import structlog

from drivers.dock_ir.edge_decoder import EdgeDecoder
from drivers.dock_ir.oi_codes import CodeTable
from drivers.dock_ir.stats import DecodeStats, total
from drivers.dock_ir.window import CodeWindow
from hal.devices import DeviceUnavailable
from hal.latest import LatestValue
from hal.ports import IrEdge, IrEdgeSource
from hal.readings import DockIrReading

log = structlog.get_logger(__name__)

PUBLISH_PERIOD_S = 0.05  # 20 Hz, the docking control loop's rate
FLUSH_LAG_S = 0.06
"""A frame is closed by the clock only when the line has been quiet this long past its gap:
edges reach us in batches (lgpio: up to 20 ms late), and a frame whose last edges are still
in the port's buffer must not be taken for cut short."""
RETRY_S = 1.0

CodeListener = Callable[[str, int, int], object]
"""Called with (receiver, code, t_us) for every code decoded."""


class DockIrReceivers:
    """The dock IR receivers as one device.

    Args:
        open_source: opens the edge port (raises DeviceUnavailable or OSError).
        receivers: the receiver names the port's edges carry.
        table: code -> beam names; window_s: how long a code stays seen.
        active_low: a mark is a low level (demodulating receivers); tolerance: of each pulse
            width, as a fraction (0.25 = the OI's +-25 %).
    """

    def __init__(self, open_source: Callable[[], IrEdgeSource], *,
                 receivers: tuple[str, ...], table: CodeTable | None = None,
                 window_s: float = 0.2, active_low: bool = True, tolerance: float = 0.25,
                 publish_period_s: float = PUBLISH_PERIOD_S, flush_lag_s: float = FLUSH_LAG_S,
                 name: str = "dock_ir") -> None:
        self.name = name
        self._open_source = open_source
        self.table = table if table is not None else CodeTable.build()
        self.stats = {r: DecodeStats() for r in receivers}
        self._decoders = {r: EdgeDecoder(active_low=active_low, tolerance=tolerance,
                                         stats=self.stats[r]) for r in receivers}
        self.window = CodeWindow(receivers, window_s)
        self.publish_period_s = publish_period_s
        self.flush_lag_us = round(flush_lag_s * 1e6)
        self._source: IrEdgeSource | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._latest: LatestValue[DockIrReading] = LatestValue()
        self._listeners: list[CodeListener] = []
        self.foreign_edges = 0  # edges of a receiver we were not told of
        self.line_errors = 0
        self.last_error: str | None = None

    # --- DockIr -----------------------------------------------------------------------------
    async def start(self) -> None:
        if self._tasks:
            return
        try:
            self._source = self._open_source()
        except OSError as exc:
            msg = f"{self.name}: cannot open the receivers' GPIO lines ({exc})"
            raise DeviceUnavailable(msg) from exc
        for decoder in self._decoders.values():
            decoder.reset()
        self._tasks = [asyncio.create_task(self._read(), name=f"{self.name}.reader"),
                       asyncio.create_task(self._publish(), name=f"{self.name}.publisher")]

    async def close(self) -> None:
        """Stop reading and release the lines; safe to call twice."""
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        source, self._source = self._source, None
        if source is not None:
            source.close()

    def latest(self) -> DockIrReading | None:
        return self._latest.latest()

    async def next_reading(self) -> DockIrReading:
        return await self._latest.next()

    def on_code(self, listener: CodeListener) -> Callable[[], None]:
        """Call ``listener(receiver, code, t_us)`` for each code decoded; returns the stop."""
        self._listeners = [*self._listeners, listener]

        def stop() -> None:
            self._listeners = [cb for cb in self._listeners if cb is not listener]

        return stop

    def status(self) -> dict[str, Any]:
        latest = self.latest()
        seen = {} if latest is None else {r: sorted(c) for r, c in latest.codes.items()}
        return {"running": bool(self._tasks), "window_s": self.window.window_us / 1e6,
                "seen": seen, "total": total(list(self.stats.values())).as_dict(),
                "receivers": {r: s.as_dict() for r, s in self.stats.items()},
                "foreign_edges": self.foreign_edges, "line_errors": self.line_errors,
                "last_error": self.last_error, "quiet_s": self.quiet_s()}

    def quiet_s(self) -> dict[str, float | None]:
        """Seconds since each receiver's last edge (None: none yet). A receiver whose cable is
        out stays quiet, but so does one that sees no emitter: this shows it, it cannot tell."""
        source = self._source
        now_us = None if source is None else source.now_us()
        out: dict[str, float | None] = {}
        for receiver, decoder in self._decoders.items():
            last = decoder.last_edge_us
            out[receiver] = None if now_us is None or last is None \
                else round(max(0, now_us - last) / 1e6, 2)
        return out

    def apply_setting(self, dotted: str, value: Any) -> None:
        """A tuned ``docking.ir_window_s`` takes effect at once."""
        if dotted == "docking.ir_window_s":
            self.window.set_window(float(value))

    # --- decoding ---------------------------------------------------------------------------
    def feed(self, edges: list[IrEdge]) -> None:
        """Decode a batch of edges (the reader task's work; tests and replays call it too)."""
        decoders = self._decoders
        for edge in edges:
            decoder = decoders.get(edge.receiver)
            if decoder is None:
                self.foreign_edges += 1
                continue
            code = decoder.feed(edge.level, edge.t_us)
            if code is not None:
                self._took(edge.receiver, code, edge.t_us)

    def flush(self, quiet_until_us: int) -> None:
        """Close the frames whose gap had passed by ``quiet_until_us`` (every edge before that
        time must have been fed)."""
        for receiver, decoder in self._decoders.items():
            code = decoder.flush(quiet_until_us)
            if code is not None:
                self._took(receiver, code, quiet_until_us)

    def reading(self, now_us: int, t_s: float) -> DockIrReading:
        codes = self.window.seen(now_us)
        beams = {r: frozenset(b for c in cs for b in self.table.beams(c))
                 for r, cs in codes.items()}
        return DockIrReading(codes=codes, beams=beams, t_s=t_s)

    def _took(self, receiver: str, code: int, t_us: int) -> None:
        if not self.table.known(code):
            self.stats[receiver].unknown_codes += 1
        self.window.add(receiver, code, t_us)
        for listener in self._listeners:
            try:
                listener(receiver, code, t_us)
            except Exception:
                log.exception("dock_ir.listener_failed", listener=repr(listener))

    async def _read(self) -> None:
        assert self._source is not None
        source = self._source
        while True:
            try:
                edges = await source.next_edges()
            except Exception as exc:  # lgpio.error, OSError: the GPIO chip went away
                self.line_errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
                log.warning("dock_ir.line_error", error=self.last_error, retry_s=RETRY_S)
                await asyncio.sleep(RETRY_S)
                continue
            self.feed(edges)

    async def _publish(self) -> None:
        assert self._source is not None
        source = self._source
        loop = asyncio.get_running_loop()
        while True:
            await asyncio.sleep(self.publish_period_s)
            now_us = source.now_us()
            self.flush(now_us - self.flush_lag_us)
            self._latest.publish(self.reading(now_us, loop.time()))
