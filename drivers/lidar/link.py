"""The LD19 LiDAR as a device: opens the port, parses, publishes scans, notices staleness.

The LD19 only talks (one-way, 230400 8N1): there is no handshake, so the link is "up" once
the port opens and intact packets arrive. When the port fails or reaches end of file the
driver reopens it with exponential backoff (the seed: LiDAR lost, retry every 5 s, so the
backoff is capped at ``lidar.reconnect_max_s``). A scan older than ``lidar.stale_s`` marks
the device stale: a ``lidar.stale`` event, ``status()["stale"]``, the stale listeners, and
waiters in ``next_reading`` get ``LidarStale``. All times are the event loop's.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import structlog

from drivers.lidar.config import LidarConfig
from drivers.lidar.parser import PacketParser
from drivers.lidar.scan_assembler import ScanAssembler
from drivers.lidar.stats import snapshot
from hal.devices import DeviceUnavailable, LidarStale
from hal.latest import LatestValue
from hal.ports import SerialOpener
from hal.readings import LidarScan
from hal.tasks import cancel_and_wait, reconnect_forever

log = structlog.get_logger(__name__)

READ_BYTES = 65536
FIRST_PACKET_TIMEOUT_S = 3.0  # the LD19 sends within ~1 s of power; allow a slow spin-up


class Ld19Lidar:
    """The LD19 (or STL-19P) on a serial port (a ``hal.devices.Lidar``).

    Args:
        opener: opens the port as a stream pair (``drivers.serial_port.open_serial`` on the
            robot, ``sim.devices.sim_serial.SimSerialPorts`` in the simulator).
        config: port, model, mount and timings.
        name: device name in ``status`` and logs.
    """

    def __init__(self, opener: SerialOpener, config: LidarConfig | None = None, *,
                 name: str = "lidar") -> None:
        self.name = name
        self.config = config or LidarConfig()
        self._opener = opener
        self.parser = PacketParser(self.config.model)
        self.assembler = ScanAssembler(self.config)
        self.connected = False
        self.reconnects = 0
        self.stale_events = 0
        self._latest: LatestValue[LidarScan] = LatestValue()
        self._stale = False
        self._stale_callbacks: list[Callable[[bool], None]] = []
        self._last_scan_s = 0.0
        self._stale_timer: asyncio.TimerHandle | None = None
        self._task: asyncio.Task[None] | None = None
        self._first: asyncio.Future[str | None] | None = None
        self._opens = 0

    # -- Device ------------------------------------------------------------------------------
    async def start(self) -> None:
        """Open the port and wait for the first intact packet; DeviceUnavailable otherwise."""
        if self._task is not None:
            return
        loop = asyncio.get_running_loop()
        self._first = loop.create_future()
        self._last_scan_s = loop.time()
        self._arm_stale_timer()
        self._task = loop.create_task(self._supervise(), name=f"{self.name}-link")
        error = await self._first
        if error is not None:
            await self.close()
            msg = f"{self.name} on {self.config.port}: {error}"
            raise DeviceUnavailable(msg)

    async def close(self) -> None:
        """Close the port; safe to call twice."""
        # The stale timer first: closing takes loop time (the connection unwinds), and a
        # scan due meanwhile is not stale, the LiDAR is being shut down.
        if self._stale_timer is not None:
            self._stale_timer.cancel()
            self._stale_timer = None
        task, self._task = self._task, None
        await cancel_and_wait(task)

    def status(self) -> dict[str, Any]:
        figures = snapshot(self.parser.counters, self.assembler.counters)
        loop_time = asyncio.get_running_loop().time() if self._task is not None else None
        return {
            "port": self.config.port, "model": self.config.model.value,
            "connected": self.connected, "stale": self._stale,
            "since_scan_s": None if loop_time is None else round(loop_time - self._last_scan_s, 3),
            "reconnects": self.reconnects, "stale_events": self.stale_events, **figures,
        }

    # -- Lidar -------------------------------------------------------------------------------
    @property
    def stale(self) -> bool:
        return self._stale

    def latest(self) -> LidarScan | None:
        return self._latest.latest()

    async def next_reading(self) -> LidarScan:
        """The next scan; LidarStale when the LiDAR is stale or goes stale first."""
        if self._stale:
            msg = f"{self.name} on {self.config.port}: stale (no scan for {self.config.stale_s} s)"
            raise LidarStale(msg)
        return await self._latest.next()

    def listen(self, callback: Callable[[LidarScan], object]) -> Callable[[], None]:
        return self._latest.listen(callback)

    def on_stale_change(self, callback: Callable[[bool], None]) -> None:
        self._stale_callbacks.append(callback)

    # -- connection lifecycle ----------------------------------------------------------------
    async def _supervise(self) -> None:
        await reconnect_forever(
            self._connect_once, first=self._first, min_s=self.config.reconnect_min_s,
            max_s=self.config.reconnect_max_s,
            on_wait=lambda wait_s: log.info("lidar.reconnect_wait", port=self.config.port,
                                            wait_s=wait_s))

    async def _connect_once(self) -> str | None:
        """One connection from open to loss; None when packets flowed, else why not."""
        try:
            reader, writer = await self._opener(self.config.port, self.config.baud)
        except OSError as exc:
            log.info("lidar.open_failed", port=self.config.port, error=str(exc))
            return f"cannot open the port: {exc}"
        self._opens += 1
        if self._opens > 1:
            self.reconnects += 1
        self.parser.reset()
        self.assembler.reset()
        self.connected = True
        log.info("lidar.up", port=self.config.port, reconnects=self.reconnects)
        reason = "end of file"
        try:
            if self._first is not None and not self._first.done():
                error = await self._wait_first_packet(reader)
                self._first.set_result(error)
                if error is not None:
                    return error
            while True:
                data = await reader.read(READ_BYTES)
                if not data:
                    break
                self._on_bytes(data)
            return None
        except asyncio.CancelledError:
            reason = "closed"
            raise
        except OSError as exc:
            reason = str(exc)
            return None if self.parser.counters.packets else f"the port failed: {exc}"
        finally:
            self.connected = False
            writer.close()
            if reason == "closed":
                log.info("lidar.closed", port=self.config.port)
            else:
                log.warning("lidar.down", port=self.config.port, reason=reason)

    async def _wait_first_packet(self, reader: asyncio.StreamReader) -> str | None:
        loop = asyncio.get_running_loop()
        deadline_s = loop.time() + FIRST_PACKET_TIMEOUT_S
        while self.parser.counters.packets == 0:
            left_s = deadline_s - loop.time()
            try:
                data = await asyncio.wait_for(reader.read(READ_BYTES), max(0.0, left_s))
            except TimeoutError:
                data = None
            if not data:
                return (f"no LD19 packets within {FIRST_PACKET_TIMEOUT_S} s "
                        f"({self.parser.counters.bytes} bytes; check lidar.port and the baud)")
            self._on_bytes(data)
        return None

    # -- data --------------------------------------------------------------------------------
    def _on_bytes(self, data: bytes) -> None:
        now_s = asyncio.get_running_loop().time()
        scans = self.assembler.add(self.parser.feed(data), now_s)
        if not scans:
            return
        self._last_scan_s = now_s
        if self._stale:
            self._set_stale(False)
        for scan in scans:
            self._latest.publish(scan)

    def _arm_stale_timer(self) -> None:
        loop = asyncio.get_running_loop()
        self._stale_timer = loop.call_at(self._last_scan_s + self.config.stale_s, self._check_stale)

    def _check_stale(self) -> None:
        """Runs when the newest scan may be too old; re-arms itself from the newest scan."""
        now_s = asyncio.get_running_loop().time()
        if not self._stale and now_s - self._last_scan_s >= self.config.stale_s:
            self._set_stale(True)
        due_s = self._last_scan_s + self.config.stale_s
        self._stale_timer = asyncio.get_running_loop().call_at(
            due_s if due_s > now_s else now_s + self.config.stale_s, self._check_stale)

    def _set_stale(self, stale: bool) -> None:
        self._stale = stale
        now_s = asyncio.get_running_loop().time()
        if stale:
            self.stale_events += 1
            since_s = round(now_s - self._last_scan_s, 3)
            log.warning("lidar.stale", port=self.config.port, since_scan_s=since_s,
                        connected=self.connected)
            why = "connected, no intact turn" if self.connected else "port down"
            self._latest.fail(LidarStale(f"{self.name} on {self.config.port}: no scan for "
                                         f"{since_s} s ({why})"))
        else:
            log.info("lidar.fresh", port=self.config.port)
        for callback in list(self._stale_callbacks):
            try:
                callback(stale)
            except Exception:
                log.exception("lidar.callback_failed", callback=repr(callback))
