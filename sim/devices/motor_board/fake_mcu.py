"""The motor board's side of the serial protocol, on a simulated plant, over any byte stream.

``FakeMcu`` behaves like the firmware (``firmware/robotd_mcu``): it reads lines of at most 64
bytes, answers ``#SEQ ACK`` / ``#SEQ NAK:<CRC|PARSE|RANGE>`` / ``#SEQ HELLO:<fw>,<protocol>``,
drops a frame whose SEQ it cannot read, acknowledges a resend of the SEQ it executed last
without executing it again, drives a ``MotorPlant``, sends ``ENCODER``/``IR``/``BAT``
telemetry at fixed rates (and the docking lines the world feeds: ``dock_inputs``), records
``EVAC``, and stops the motors 500 ms after the last ``MOTOR``/``HB``.
Lines starting with ``#`` are crc framing, others plain; telemetry follows the framing of the
last good command. Fault switches: ``unplug()``, ``replug()``, ``corrupt(pct)``,
``delay(s)``, ``reset()``. Frame parsing is in ``mcu_frames``, the serial port (line assembly,
damaged and delayed transmission) in ``mcu_uart`` (both beside this module).
"""

from __future__ import annotations

import asyncio
import collections
import functools
from collections.abc import Callable

import structlog

from hal.looptime.timer_chain import timer_chain
from hal.ports import StreamPair
from sim.devices.byte_pipe import BytePipe
from sim.devices.motor_board.dock_inputs import DockInputs
from sim.devices.motor_board.mcu_frames import (
    HEX_BYTE,
    Executed,
    ParseError,
    crc8_fast,
    crc8_join,
    parse_payload,
    read_seq,
    telemetry_line,
)
from sim.devices.motor_board.mcu_uart import McuUart
from sim.world.plant import MotorPlant

log = structlog.get_logger(__name__)

# Executed(t_s, seq, payload) without the generated __new__'s Python frame (a record per command).
_new_executed: Callable[[tuple[float, int | None, str]], Executed] = functools.partial(
    tuple.__new__, Executed)
# Distinct command payloads whose parse is remembered (a drive sends a few dozen, over and over).
_PAYLOADS_KEPT = 1024


class FakeMcu(DockInputs):
    """A simulated motor board. Records what it executed; has a bench's fault switches.

    Args:
        plant: what the motors, servo, encoders, range sensor and battery are.
        seed: seed for the corruption generator.
        deadman_s: motors stop this long after the last MOTOR/HB (None: never, as old sketches).
        announce_boot: send ``BOOT:<fw>,<protocol>`` on reset (the driver keeps encoders
            continuous with it).
        reset_on_open: restart whenever the port is opened, as an Arduino Uno does when DTR
            toggles; ``boot_s`` is how long it then ignores the line (its bootloader).
    """

    def __init__(self, plant: MotorPlant, *, firmware: str = "fake-mcu-1.0", protocol: int = 1,
                 seed: int = 0, deadman_s: float | None = 0.5, encoder_period_s: float = 0.05,
                 ir_period_s: float = 0.2, battery_period_s: float = 0.2,
                 announce_boot: bool = True, reset_on_open: bool = False,
                 boot_s: float = 0.0, history: int = 100_000) -> None:
        self.plant = plant
        self.firmware = firmware
        self.protocol = protocol
        self.deadman_s = deadman_s
        self.periods_s = {"ENCODER": encoder_period_s, "IR": ir_period_s, "BAT": battery_period_s}
        self.announce_boot, self.reset_on_open = announce_boot, reset_on_open
        self.boot_s = boot_s
        self.uart = McuUart(self._handle_line, seed=seed)
        self.executed: collections.deque[Executed] = collections.deque(maxlen=history)
        self.duplicates = 0
        self.naks: list[tuple[int | None, str]] = []
        self.dropped_frames = 0
        self.leds: list[str] = []
        self.servo_fault = False  # a jammed box servo: SERVO refused (NAK:RANGE)
        self.deadman_stops: list[float] = []
        self.boots = 0
        self.last_drive_s: float | None = None
        self.plugged = True
        self.plug_listeners: list[Callable[[bool], None]] = []
        self._init_dock_inputs()
        self._boot_state()
        self._streams: StreamPair | None = None
        self._pipe: BytePipe | None = None
        self._hangup: Callable[[], None] | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._deadman: asyncio.TimerHandle | None = None
        self._deadman_due_s = 0.0
        self._frames: dict[tuple[int, str], bytes] = {}  # framed replies, by SEQ and text
        # payload bytes -> (payload, word, arguments, NAK reply or "", CRC-8)
        self._payloads: dict[bytes, tuple[str, str, tuple[int, ...], str, int]] = {}

    def _boot_state(self) -> None:
        self.crc_framing = True
        self.motors_on = False
        self._last: tuple[int, int] | None = None  # (seq, crc) executed last
        left, right = self.plant.encoder_ticks()
        self._tick_offset = (left, right)

    @property
    def connected(self) -> bool:
        return self._streams is not None

    @property
    def corrupt_fraction(self) -> float:
        return self.uart.corrupt_fraction

    @property
    def reply_delay_s(self) -> float:
        return self.uart.reply_delay_s

    # -- wiring ------------------------------------------------------------------------------
    def connect(self, streams: StreamPair, hangup: Callable[[], None] | None = None) -> None:
        """Serve a newly opened port; ``hangup`` breaks it on ``unplug()``."""
        self.disconnect()
        self._streams = streams
        self._hangup = hangup or streams[1].transport.abort
        self.uart.attach(streams[1].transport, backlog_possible=True)
        loop = asyncio.get_running_loop()
        self._tasks = [loop.create_task(self._serve(streams[0])),
                       loop.create_task(self._telemetry())]
        if self.reset_on_open:
            self.reset()

    def connect_pipe(self, pipe: BytePipe) -> None:
        """Serve the device end of an in-memory line, taking each write as it arrives: as
        ``connect(pipe.b)`` without a reader task to wake per frame (tens a simulated second)."""
        self.disconnect()
        self._streams = pipe.b
        self._hangup = pipe.break_
        self._pipe = pipe
        self.uart.attach(pipe.b[1].transport, backlog_possible=False)  # a pipe never buffers
        pipe.receive_at_b(self.uart.receive)
        self._tasks = [asyncio.get_running_loop().create_task(self._telemetry())]
        if self.reset_on_open:
            self.reset()

    def disconnect(self) -> None:
        for task in self._tasks:
            task.cancel()
        self._tasks = []
        self._streams = None
        if self._pipe is not None:
            self._pipe.receive_at_b(None)
            self._pipe = None
        self.uart.detach()

    async def close(self) -> None:
        tasks = list(self._tasks)
        self.disconnect()
        if self._deadman is not None:
            self._deadman.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    # -- fault switches ----------------------------------------------------------------------
    def unplug(self) -> None:
        """The USB cable is pulled: the port vanishes; the board runs on (deadman included)."""
        self.plugged = False
        hangup = self._hangup
        self.disconnect()
        if hangup is not None:
            hangup()
        self._hangup = None
        log.info("fake_mcu.unplugged")
        for listener in list(self.plug_listeners):
            listener(False)

    def replug(self) -> None:
        self.plugged = True
        log.info("fake_mcu.replugged")
        for listener in list(self.plug_listeners):
            listener(True)

    def corrupt(self, pct: float) -> None:
        """Flip one bit in ``pct`` % of the bytes, in both directions."""
        self.uart.corrupt_fraction = max(0.0, min(100.0, pct)) / 100.0

    def delay(self, seconds: float) -> None:
        """Hold every outgoing line this long."""
        self.uart.reply_delay_s = max(0.0, seconds)

    def reset(self) -> None:
        """The board restarts: motors off, SEQ memory and encoder counts cleared."""
        self.boots += 1
        self.plant.apply_pwm(0, 0, True, True)
        if self._deadman is not None:
            self._deadman.cancel()
            self._deadman = None
        self._boot_state()
        log.info("fake_mcu.reset", boots=self.boots)
        loop = asyncio.get_running_loop()
        self.record_evac(False, loop.time())
        self.uart.deaf_until_s = loop.time() + self.boot_s
        if self.announce_boot:
            loop.call_at(self.uart.deaf_until_s, self._send_lines,
                         [f"BOOT:{self.firmware},{self.protocol}".encode()], True)

    # -- receiving ---------------------------------------------------------------------------
    async def _serve(self, reader: asyncio.StreamReader) -> None:
        while True:
            try:
                chunk = await reader.read(256)
            except OSError:
                return
            if not chunk:
                return
            self.uart.receive(chunk)

    def _handle_line(self, line: bytes, overlong: bool) -> None:
        if line.startswith(b"#"):
            self._handle_crc_line(line, overlong)
        elif line and not overlong:
            self._handle_plain_line(line)
        elif line:
            self.dropped_frames += 1

    def _handle_crc_line(self, line: bytes, overlong: bool) -> None:
        seq = read_seq(line)
        if seq is None:
            self.dropped_frames += 1
            return
        if overlong:
            self._reply(seq, "NAK:PARSE")
            return
        crc = HEX_BYTE.get(line[-2:])
        if line[-3:-2] != b"*" or crc is None:
            self._reply(seq, "NAK:CRC")
            return
        body = line[:-3]
        space = body.index(b" ")  # read_seq found it, before the '*'
        payload, word, args, refused, payload_crc = self._command(body[space + 1:])
        if crc != crc8_join(crc8_fast(body[:space + 1]), payload_crc, len(body) - space - 1):
            self._reply(seq, "NAK:CRC")
            return
        self.crc_framing = True
        if refused:
            self._reply(seq, refused)
            return
        if self._last == (seq, crc):
            self.duplicates += 1
            if word in ("MOTOR", "HB"):
                self._feed_deadman(self.uart.clock())
            self._reply(seq, self._hello() if word == "HELLO" else "ACK")
            return
        reply = self._execute(seq, word, args, payload)
        self._last = self._last if reply.startswith("NAK") else (seq, crc)  # NAK: not done
        self._reply(seq, reply)

    def _handle_plain_line(self, line: bytes) -> None:
        payload, word, args, refused, _ = self._command(line)
        if refused:
            self._reply(None, refused)
            return
        self.crc_framing = False
        self._reply(None, self._execute(None, word, args, payload))

    def _command(self, raw: bytes) -> tuple[str, str, tuple[int, ...], str, int]:
        """(payload, word, arguments, NAK reply or "", CRC-8 of ``raw``), worked out once
        per distinct payload."""
        command = self._payloads.get(raw)
        if command is None:
            payload = raw.decode("ascii", "replace")
            try:
                word, args = parse_payload(payload)
                command = (payload, word, args, "", crc8_fast(raw))
            except ParseError as exc:
                command = (payload, "", (), f"NAK:{exc.reason}", crc8_fast(raw))
            if len(self._payloads) >= _PAYLOADS_KEPT:
                self._payloads.clear()
            self._payloads[raw] = command
        return command

    def _execute(self, seq: int | None, word: str, args: tuple[int, ...], payload: str) -> str:
        now_s = self.uart.clock()
        self.executed.append(_new_executed((now_s, seq, payload)))
        if word == "MOTOR":
            left, right, left_dir, right_dir = args
            self.plant.apply_pwm(left, right, left_dir == 1, right_dir == 1)
            self.motors_on = left > 0 or right > 0
            self._feed_deadman(now_s)
        elif word == "HB":
            self._feed_deadman(now_s)
        elif word == "STOP":
            self._motors_off()
        elif word == "SERVO" and self.servo_fault:
            return "NAK:RANGE"
        elif word == "SERVO":
            self.plant.servo(args[0])
        elif word == "HELLO":
            return self._hello()
        elif word == "EVAC":
            self.record_evac(args[0] == 1, now_s)
        else:
            self.leds.append(word)
        return "ACK"

    def _hello(self) -> str:
        return f"HELLO:{self.firmware},{self.protocol}"

    # -- motors ------------------------------------------------------------------------------
    def _motors_off(self) -> None:
        self.plant.apply_pwm(0, 0, True, True)
        self.motors_on = False

    def _feed_deadman(self, now_s: float) -> None:
        self.last_drive_s = now_s
        if self.deadman_s is None:
            return
        # One timer per deadline that can expire: fed again meanwhile, it moves itself on
        # when it fires (no timer set and cancelled for each of 20 MOTORs a second).
        if self._deadman is None:
            self._deadman_due_s = now_s + self.deadman_s
            self._deadman = asyncio.get_running_loop().call_at(self._deadman_due_s,
                                                               self._deadman_fired)

    def _deadman_fired(self) -> None:
        self._deadman = None
        if self.deadman_s is not None and self.last_drive_s is not None:
            due_s = self.last_drive_s + self.deadman_s
            if due_s > self._deadman_due_s:
                self._deadman_due_s = due_s
                self._deadman = asyncio.get_running_loop().call_at(due_s, self._deadman_fired)
                return
        if self.motors_on:
            self._motors_off()
            now = asyncio.get_running_loop().time()
            self.deadman_stops.append(now)
            log.info("fake_mcu.deadman_stop", t_s=now, last_drive_s=self.last_drive_s)

    # -- sending -----------------------------------------------------------------------------
    def _reply(self, seq: int | None, text: str) -> None:
        if text.startswith("NAK"):
            self.naks.append((seq, text[4:]))
        if seq is None:
            self._send_lines([text.encode("ascii")], crc=False)
            return
        # Framed replies repeat every 256 commands: each is built (and its CRC run) once.
        frame = self._frames.get((seq, text))
        if frame is None:
            body = f"#{seq} {text}".encode("ascii")
            frame = self._frames[(seq, text)] = b"%s*%02X\n" % (body, crc8_fast(body))
        self.uart.send(frame)

    def _send_lines(self, bodies: list[bytes], crc: bool) -> None:
        """Frame lines and send them in one write (as a UART's buffer drains them)."""
        if self._streams is not None:
            self.uart.send(b"".join([b"%s*%02X\n" % (body, crc8_fast(body)) if crc
                                     else body + b"\n" for body in bodies]))

    async def _telemetry(self) -> None:
        # Each telemetry moment is a timer callback that sets the next one (timer_chain).
        loop = asyncio.get_running_loop()
        periods = self.periods_s
        due = {name: loop.time() + period for name, period in periods.items()}
        next_s = min(due.values())

        def send() -> float:
            nonlocal next_s
            now_s = loop.time()
            talking = now_s >= self.uart.deaf_until_s
            crc = self.crc_framing
            due_by_s = next_s + 1e-9
            data = b""
            encoder = False
            for name, due_s in due.items():
                if due_s <= due_by_s:
                    due[name] = due_s + periods[name]
                    if talking:  # lines built as they fall due: no list and join per tick
                        data += self._telemetry_line(name, crc)
                        encoder = encoder or name == "ENCODER"
            if talking:
                if encoder:
                    data += self._dock_lines(loop.time(), crc)
                if self._streams is not None:
                    self.uart.send(data)
            next_s = min(due.values())
            return max(0.0, next_s - loop.time())

        await timer_chain(send, max(0.0, next_s - loop.time()))

    def _telemetry_line(self, name: str, crc: bool) -> bytes:
        """One telemetry line, framed; its CRC continued from the name's over the fields."""
        if name == "ENCODER":
            left, right = self.plant.encoder_ticks()
            fields = b"%d,%d" % (left - self._tick_offset[0], right - self._tick_offset[1])
        elif name == "IR":
            fields = b"%d" % round(self.plant.front_range_cm())
        else:
            voltage_v, percent, on_dock = self.plant.battery()
            fields = b"%d,%d,%d" % (round(voltage_v * 1000), round(percent), on_dock)
        return telemetry_line(name, fields, crc)
