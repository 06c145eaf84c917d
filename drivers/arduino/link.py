"""The Arduino motor board driver: motors, servo, LEDs and EVAC out; encoders, range, battery
and the docking sensors in.

One ``ArduinoLink`` is the robot's ``Motors``, ``ServoBox``, ``Leds`` and ``DockStation``; its
``encoders``, ``front_range`` and ``battery`` attributes are the sensor facets, ``dock`` holds
the docking ones (``dock.signal``, ``contacts``, ``bumpers``, ``wall``, ``bin``). It opens
the port through a ``SerialOpener``, does the ``HELLO`` handshake, and reconnects with
exponential backoff when the port disappears or falls silent. While the link is down
``connected`` is False, ``drive()`` raises ``LinkDown`` and the board's own deadman has
stopped the wheels.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

import structlog

from drivers.arduino.config import LinkConfig
from drivers.arduino.framing import Framing, Telemetry, check_payload
from drivers.arduino.outbox import Command, Delivery, Outbox, Outcome
from drivers.arduino.receiver import LinkBroken
from drivers.arduino.session import Session
from drivers.arduino.stats import LinkCounters
from drivers.arduino.telemetry import Boot, DockFacets, Feed, TelemetryError, interpret
from hal.devices import DeviceUnavailable, LinkDown
from hal.ports import SerialOpener
from hal.readings import (
    BatteryReading,
    EncoderReading,
    LedMode,
    LinkStats,
    MotorCommand,
    RangeReading,
)
from hal.settings import SettingsView
from hal.tasks import cancel_and_wait, reconnect_forever

log = structlog.get_logger(__name__)

__all__ = ["ArduinoLink", "CommandNotDelivered", "Feed", "FirmwareRejected"]


class CommandNotDelivered(LinkDown):
    """A command ended without acknowledgement; ``delivery`` says how."""

    def __init__(self, delivery: Delivery) -> None:
        super().__init__(f"{delivery.payload}: {delivery.outcome.value} {delivery.detail}".strip())
        self.delivery = delivery


class FirmwareRejected(Exception):
    """The board answered HELLO with a protocol version older than accepted."""


class ArduinoLink:
    """The serial link to the motor board (DESIGN.md "Serial link to the Arduino").

    Args:
        opener: opens the port as a stream pair (``drivers.serial_port.open_serial`` on the
            robot, ``sim.devices.sim_serial.SimSerialPorts`` in the simulator).
        config: port, baud, framing and protocol timings.
        name: device name in ``status`` and logs.
    """

    def __init__(self, opener: SerialOpener, config: LinkConfig | None = None, *,
                 name: str = "arduino") -> None:
        self.name = name
        self.config = config or LinkConfig()
        self._opener = opener
        self.encoders: Feed[EncoderReading] = Feed()
        self.front_range: Feed[RangeReading] = Feed()
        self.battery: Feed[BatteryReading] = Feed()
        self.dock = DockFacets()
        self.counters = LinkCounters()
        self.firmware: str | None = None
        self.protocol: int | None = None
        self._outbox = Outbox(self.config.queue_limit)
        self._session: Session | None = None
        self._connected = False
        self._callbacks: list[Callable[[bool], None]] = []
        self._task: asyncio.Task[None] | None = None
        self._first: asyncio.Future[str | None] | None = None
        self._next_seq = 0
        self._ups = 0
        self._encoder_base = (0, 0)
        self._last_raw_ticks = (0, 0)
        self.last_down_reason = ""
        self._closing = False

    @classmethod
    def from_settings(cls, opener: SerialOpener, settings: SettingsView, *,
                      name: str = "arduino") -> ArduinoLink:
        return cls(opener, LinkConfig.from_settings(settings), name=name)

    # -- Device ------------------------------------------------------------------------------
    async def start(self) -> None:
        """Open the port and shake hands; DeviceUnavailable when the first attempt fails."""
        if self._task is not None:
            return
        loop = asyncio.get_running_loop()
        self._first = loop.create_future()
        self._closing = False
        self._task = loop.create_task(self._supervise(), name=f"{self.name}-link")
        error = await self._first
        if error is not None:
            await self.close()
            msg = f"{self.name} on {self.config.port}: {error}"
            raise DeviceUnavailable(msg)

    async def close(self) -> None:
        """Stop the wheels if possible, then close the port; safe to call twice."""
        if self._connected:
            with contextlib.suppress(LinkDown, TimeoutError):
                await asyncio.wait_for(self.stop(), self.config.ack_timeout_s)
        self._closing = True
        task, self._task = self._task, None
        await cancel_and_wait(task)

    def status(self) -> dict[str, Any]:
        stats = self.link_stats()
        return {
            "port": self.config.port, "framing": self.config.framing.value,
            "connected": stats.connected, "firmware": stats.firmware, "protocol": self.protocol,
            "sent": stats.sent, "acked": stats.acked, "resent": stats.resent, "lost": stats.lost,
            "dropped": stats.dropped, "crc_errors": stats.crc_errors, "nak": stats.nak,
            "reconnects": stats.reconnects, "rtt_p50_ms": stats.rtt_p50_ms,
            "rtt_p99_ms": stats.rtt_p99_ms, "queued": len(self._outbox),
            **self.counters.extras(),
            "superseded": self.counters.superseded + self._outbox.superseded,
            **self.dock.status(),
        }

    # -- Motors ------------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        return self._connected

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        self._callbacks.append(callback)

    def link_stats(self) -> LinkStats:
        return self.counters.snapshot(connected=self._connected, dropped=self._outbox.dropped,
                                      firmware=self.firmware)

    async def drive(self, command: MotorCommand) -> None:
        """Queue a wheel command (replacing a queued older one); LinkDown while down.

        Returns once queued: a control loop never stalls behind a resend.
        """
        payload = (f"MOTOR:{command.left_pwm},{command.right_pwm},"
                   f"{int(command.left_forward)},{int(command.right_forward)}")
        self._queue(payload, None, checked=True)  # built here from a MotorCommand: well-formed

    async def stop(self) -> None:
        """Stop the wheels now, ahead of everything queued; never raises.

        While the link is down there is nothing to send: the board's deadman stopped them.
        """
        if not self._connected:
            return
        delivery = await self.submit("STOP")
        if not delivery.ok:
            log.warning("link.stop_unconfirmed", outcome=delivery.outcome.value,
                        detail=delivery.detail)

    # -- ServoBox and Leds -------------------------------------------------------------------
    async def set_angle(self, angle_deg: int) -> None:
        """Move the box servo (0-180 degrees); waits for the acknowledgement."""
        if not 0 <= angle_deg <= 180:
            msg = f"servo angle must be 0-180 degrees, got {angle_deg}"
            raise ValueError(msg)
        delivery = await self.submit(f"SERVO:{angle_deg}")
        if not delivery.ok:
            raise CommandNotDelivered(delivery)

    async def show(self, mode: LedMode) -> None:
        """Queue an LED effect; skipped while the link is down (LEDs are cosmetic)."""
        if not self._connected:
            log.debug("link.led_skipped", mode=mode.value)
            return
        self.submit(mode.value)

    # -- DockStation -------------------------------------------------------------------------
    async def evacuate(self, on: bool) -> None:
        """Ask the station to run (True) or stop (False) its suction: ``EVAC:<0|1>``."""
        delivery = await self.submit(f"EVAC:{int(on)}")
        if not delivery.ok:
            raise CommandNotDelivered(delivery)

    # -- any command -------------------------------------------------------------------------
    def submit(self, payload: str) -> asyncio.Future[Delivery]:
        """Queue ``payload``; the future ends with its Delivery. LinkDown while down."""
        future: asyncio.Future[Delivery] = asyncio.get_running_loop().create_future()
        self._queue(payload, future)
        return future

    def _queue(self, payload: str, future: asyncio.Future[Delivery] | None, *,
               checked: bool = False) -> None:
        if not self._connected or self._session is None:
            why = self.last_down_reason or "not connected yet"
            msg = f"{self.name} on {self.config.port}: link is down ({why})"
            raise LinkDown(msg)
        if not checked:
            check_payload(payload, self.config.framing)
        command = Command(payload, future)
        self._outbox.put(command)
        if command.payload == "STOP":
            self._session.preempt()

    async def command(self, payload: str) -> Delivery:
        """Send ``payload`` and wait for how it ended (for probes and tests)."""
        return await self.submit(payload)

    async def wait_connected(self, timeout_s: float | None = None) -> bool:
        """Wait until the link is up; False when ``timeout_s`` passed first."""
        if self._connected:
            return True
        up = asyncio.get_running_loop().create_future()

        def on_change(connected: bool) -> None:
            if connected and not up.done():
                up.set_result(True)

        self._callbacks.append(on_change)
        try:
            await asyncio.wait_for(up, timeout_s)
            return True
        except TimeoutError:
            return False
        finally:
            self._callbacks.remove(on_change)

    # -- connection lifecycle ----------------------------------------------------------------
    async def _supervise(self) -> None:
        await reconnect_forever(
            self._connect_once, first=self._first, min_s=self.config.reconnect_min_s,
            max_s=self.config.reconnect_max_s, running=lambda: not self._closing,
            on_wait=lambda wait_s: log.info("link.reconnect_wait", port=self.config.port,
                                            wait_s=wait_s))

    async def _connect_once(self) -> str | None:
        """One connection from open to break; None when it got up, else why it did not."""
        try:
            streams = await self._opener(self.config.port, self.config.baud)
        except OSError as exc:
            log.info("link.open_failed", port=self.config.port, error=str(exc))
            return f"cannot open the port: {exc}"
        session = Session(streams, self.config, self._outbox, self.counters,
                          self._on_telemetry, self._next_seq)
        session.start()
        reason = "closed"
        try:
            try:
                await self._handshake(session)
            except (LinkBroken, OSError, FirmwareRejected, TimeoutError) as exc:
                log.warning("link.handshake_failed", port=self.config.port, error=str(exc))
                return f"handshake failed: {exc}"
            self._session = session
            self._set_connected(True)
            session.start_keepalive()
            if self._first is not None and not self._first.done():
                self._first.set_result(None)
            reason = str(await session.wait_broken())
            return None
        finally:
            self._next_seq = session.next_seq
            self._session = None
            self._outbox.clear(Outcome.LINK_DOWN, "link went down")
            await session.close()
            if self._connected:
                self.last_down_reason = reason
                self._set_connected(False)
                down = LinkDown(f"{self.name} on {self.config.port}: {reason}")
                for feed in (self.encoders, self.front_range, self.battery):
                    feed.fail(down)
                self.dock.fail(down)
                if self._closing:
                    log.info("link.closed", port=self.config.port)
                else:
                    log.warning("link.down", port=self.config.port, reason=reason)

    async def _handshake(self, session: Session) -> None:
        if self.config.framing is Framing.PLAIN:
            return
        loop = asyncio.get_running_loop()
        deadline_s = loop.time() + self.config.handshake_timeout_s
        while loop.time() < deadline_s:
            hello: asyncio.Future[Delivery] = loop.create_future()
            self._outbox.put(Command("HELLO", hello))
            delivery = await asyncio.wait_for(session.race(hello),
                                              max(0.0, deadline_s - loop.time()))
            if delivery.ok and delivery.detail:
                firmware, _, protocol = delivery.detail.rpartition(",")
                self._accept_firmware(firmware, int(protocol))
                return
        msg = f"no HELLO reply within {self.config.handshake_timeout_s} s"
        raise TimeoutError(msg)

    def _accept_firmware(self, firmware: str, protocol: int) -> None:
        if protocol < self.config.min_firmware_protocol:
            log.error("link.firmware_rejected", firmware=firmware, protocol=protocol,
                      min_protocol=self.config.min_firmware_protocol)
            msg = (f"firmware {firmware!r} speaks protocol {protocol}, serial."
                   f"min_firmware_protocol is {self.config.min_firmware_protocol}")
            raise FirmwareRejected(msg)
        self.firmware, self.protocol = firmware, protocol

    def _set_connected(self, connected: bool) -> None:
        self._connected = connected
        if connected:
            self._ups += 1
            if self._ups > 1:
                self.counters.reconnects += 1
            log.info("link.up", port=self.config.port, firmware=self.firmware,
                     protocol=self.protocol, reconnects=self.counters.reconnects)
        for callback in list(self._callbacks):
            try:
                callback(connected)
            except Exception:
                log.exception("link.callback_failed", callback=repr(callback))

    # -- telemetry ---------------------------------------------------------------------------
    def _on_telemetry(self, line: Telemetry, now: float) -> None:
        """A telemetry line, received at loop time ``now``."""
        try:
            reading = interpret(line, now)
        except TelemetryError as exc:
            self.counters.bad_telemetry += 1
            log.info("link.bad_telemetry", error=str(exc))
            return
        if reading is None:
            self.counters.unknown_telemetry += 1
        elif isinstance(reading, EncoderReading):
            self._last_raw_ticks = (reading.left_ticks, reading.right_ticks)
            base_left, base_right = self._encoder_base
            if base_left or base_right:  # the board restarted: continue from its old counts
                reading = EncoderReading(reading.left_ticks + base_left,
                                         reading.right_ticks + base_right, now)
            self.encoders.publish(reading)
        elif isinstance(reading, RangeReading):
            self.front_range.publish(reading)
        elif isinstance(reading, BatteryReading):
            self.battery.publish(reading)
        elif isinstance(reading, Boot):
            self._on_boot(reading)
        else:
            self.dock.publish(reading)

    def _on_boot(self, boot: Boot) -> None:
        """The board restarted: its counters start at zero, so keep ours continuous."""
        self.counters.mcu_resets += 1
        base_left, base_right = self._encoder_base
        raw_left, raw_right = self._last_raw_ticks
        self._encoder_base = (base_left + raw_left, base_right + raw_right)
        self._last_raw_ticks = (0, 0)
        log.warning("link.mcu_reset", firmware=boot.firmware, protocol=boot.protocol)


