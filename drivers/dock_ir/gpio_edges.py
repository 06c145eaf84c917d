"""``hal.ports.IrEdgeSource`` on a Raspberry Pi's GPIO lines through ``lgpio`` alerts.

lgpio reports each level change of a claimed alert line with its level and a kernel timestamp
in nanoseconds (CLOCK_REALTIME: ``lguTimestamp`` is "nanoseconds since the epoch"), so the
widths are measured by the kernel at the interrupt, not by when Python gets round to them.
lgpio's Python module delivers these reports by calling our function from its own thread (its
callback API offers no other way): that thread only appends to a buffer, and wakes the event
loop with ``call_soon_threadsafe`` when the buffer goes from empty to not empty. The loop then
waits ``batch_s`` more, so it wakes about 1 / batch_s times a second, never once per edge.

lgpio is imported only when the lines are opened (the optional ``pi`` extra, or Raspberry Pi
OS's ``python3-lgpio``).
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any

from hal.devices import DeviceUnavailable
from hal.ports import IrEdge

BATCH_S = 0.02
WATCHDOG_LEVEL = 2  # lgpio reports a watchdog timeout as level 2: not an edge


def _import_lgpio() -> Any:
    try:
        import lgpio
    except ImportError as exc:
        msg = ("dock_ir: the lgpio module is missing; install robotd with the pi extra "
               "(pip install 'robotd[pi]') or apt install python3-lgpio")
        raise DeviceUnavailable(msg) from exc
    return lgpio


class LgpioIrEdges:
    """The receivers' lines on ``/dev/gpiochipN`` as alert inputs, edges in batches."""

    def __init__(self, chip: int, lines: dict[str, int], loop: asyncio.AbstractEventLoop, *,
                 batch_s: float = BATCH_S, lgpio_module: Any | None = None) -> None:
        self._lg = lgpio_module if lgpio_module is not None else _import_lgpio()
        self._loop = loop
        self.batch_s = batch_s
        self._names = {gpio: name for name, gpio in lines.items()}
        self._buffer: list[IrEdge] = []
        self._lock = threading.Lock()
        self._wake = asyncio.Event()
        self._callbacks: list[Any] = []
        try:
            self._handle = self._lg.gpiochip_open(chip)
        except Exception as exc:  # lgpio raises its own lgpio.error
            msg = f"dock_ir: cannot open /dev/gpiochip{chip} ({exc}); check docking.ir_gpiochip"
            raise DeviceUnavailable(msg) from exc
        try:
            for gpio in self._names:
                self._lg.gpio_claim_alert(self._handle, gpio, self._lg.BOTH_EDGES)
                self._callbacks.append(
                    self._lg.callback(self._handle, gpio, self._lg.BOTH_EDGES, self._on_alert))
        except Exception as exc:
            self.close()
            msg = (f"dock_ir: cannot claim GPIO {gpio} ({self._names[gpio]}) on gpiochip{chip} "
                   f"({exc}); is another program using it?")
            raise DeviceUnavailable(msg) from exc

    def _on_alert(self, _chip: int, gpio: int, level: int, timestamp_ns: int) -> None:
        """lgpio's thread: keep the edge; wake the loop only for the first of a batch."""
        if level == WATCHDOG_LEVEL:
            return
        edge = IrEdge(self._names.get(gpio, f"gpio{gpio}"), bool(level), timestamp_ns // 1000)
        with self._lock:
            self._buffer.append(edge)
            first = len(self._buffer) == 1
        if first:
            with contextlib.suppress(RuntimeError):  # the loop closed while we shut down
                self._loop.call_soon_threadsafe(self._wake.set)

    async def next_edges(self) -> list[IrEdge]:
        while True:
            self._wake.clear()
            with self._lock:
                waiting = bool(self._buffer)
            if waiting:
                await asyncio.sleep(self.batch_s)  # let the rest of the frame come
                with self._lock:
                    batch, self._buffer = self._buffer, []
                return batch
            await self._wake.wait()

    def now_us(self) -> int:
        # The alerts' clock (CLOCK_REALTIME); a step of the system clock shows as one long
        # gap, or as a backwards edge that the decoder counts (clock_steps).
        return time.time_ns() // 1000

    def close(self) -> None:
        callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            with contextlib.suppress(Exception):
                cb.cancel()
        handle, self._handle = getattr(self, "_handle", None), None
        if handle is None:
            return
        for gpio in self._names:
            with contextlib.suppress(Exception):  # closing anyway
                self._lg.gpio_free(handle, gpio)
        with contextlib.suppress(Exception):
            self._lg.gpiochip_close(handle)


def lgpio_edges_opener(chip: int, lines: dict[str, int]) -> Callable[[], LgpioIrEdges]:
    """What ``DockIrReceivers`` takes as ``open_source`` on a Pi (call it on the loop)."""
    return lambda: LgpioIrEdges(chip, lines, asyncio.get_running_loop())
