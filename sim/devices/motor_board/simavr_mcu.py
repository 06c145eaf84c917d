"""The real motor-board firmware in an emulated ATmega328P (simavr), as a simulated MCU.

``SimavrMcu`` builds the sketch and the harness (``firmware/Makefile``) when needed, runs the
harness as a subprocess, and gives the sketch's UART as a pseudo-terminal path that the real
Arduino driver opens like ``/dev/ttyACM0``. Its pins (PWM duty and H-bridge inputs per motor,
servo pulse, LEDs, EVAC) are read from the harness's control channel; encoder edges, the IR
range, the battery voltage and the docking sensors (behind the board's 74HC4051) are injected
through it.

``simavr_bridge.SimavrBridge`` (beside this module) closes the loop with the simulated body.
The emulator runs in wall time, so both need a real event loop (``robotd sim --realtime``),
not virtual time.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes.util
import shutil
import signal
import subprocess
import tempfile
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import structlog

from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

FIRMWARE_DIR = Path(__file__).resolve().parents[3] / "firmware"
ELF_PATH = FIRMWARE_DIR / "build" / "robotd_mcu" / "robotd_mcu.elf"
HARNESS_PATH = FIRMWARE_DIR / "build" / "harness" / "robotd_harness"

# Hardware facts shared with firmware/robotd_mcu/robotd_mcu.ino (see docs/firmware.md).
ADC_IR = 0
ADC_BATTERY = 1
ADC_REF_MV = 5000
IR_K = 9462  # Sharp GP2Y0A02 fit: cm = IR_K / (adc - IR_ADC_OFFSET)
IR_ADC_OFFSET = 17
BATTERY_DIVIDER = 3
# The docking multiplexer's inputs (firmware/robotd_mcu/dock_io.h).
MUX_CONTACTS, MUX_IRS_L, MUX_IRS_R, MUX_WALL, MUX_BIN, MUX_BUMP_L, MUX_BUMP_R = range(7)
CONTACT_DIVIDER = 6
WALL_K = 2076  # Sharp GP2Y0A41SK0F fit: cm = WALL_K / (adc - WALL_ADC_OFFSET)
WALL_ADC_OFFSET = 11
BIN_EMPTY_MV, BIN_FULL_MV = 500, 4500
SERVO_MIN_US = 544
SERVO_MAX_US = 2400
# Each program the build runs, with the Debian package that brings it.
_TOOLS = {"make": "make", "avr-gcc": "gcc-avr", "avr-size": "binutils-avr", "cc": "gcc",
          "pkg-config": "pkg-config", "flock": "util-linux"}
# Each file the build reads (headers, make rules, the Arduino core, libraries to link), with
# its package: the harness links -lsimavr -lelf (firmware/Makefile), simavr's pkg-config
# file requires libelf's, and the sketch builds against avr-libc and the Arduino core.
_FILES = (
    ("simavr's headers (sim_avr.h)", "libsimavr-dev", ("/usr/include/simavr/sim_avr.h",)),
    ("libelf's headers (libelf.h, gelf.h)", "libelf-dev",
     ("/usr/include/libelf.h", "/usr/include/gelf.h")),
    ("avr-libc (avr/io.h)", "avr-libc", ("/usr/lib/avr/include/avr/io.h",)),
    ("the Arduino AVR core (Arduino.h)", "arduino-core-avr",
     ("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h",)),
    ("Arduino.mk", "arduino-mk", ("/usr/share/arduino/Arduino.mk",)),
)
# Libraries found through pkg-config (name, package) and the loader (name, package).
_PKG_CONFIG = (("libelf", "libelf-dev"), ("simavr", "libsimavr-dev"))
_SHARED_LIBS = (("simavr", "libsimavr2"), ("simavrparts", "libsimavrparts1"),
                ("elf", "libelf1"))


_FAULT_REPLIES = [["OK", name] for name in ("CORRUPT", "DELAY", "UNPLUG", "REPLUG", "RESET")]


class SimavrUnavailable(RuntimeError):
    """The AVR toolchain, arduino-mk or simavr is missing, or the build failed."""


def missing_toolchain() -> str | None:
    """Why the firmware cannot be built and emulated here, or None when it can: each missing
    program, file or library by name, with the Debian package that brings it."""
    missing = [f"{tool} ({package})" for tool, package in _TOOLS.items()
               if shutil.which(tool) is None]
    missing += [f"{what} ({package})" for what, package, paths in _FILES
                if not all(Path(path).exists() for path in paths)]
    if shutil.which("pkg-config") is not None:
        missing += [f"{name}.pc for pkg-config ({package})" for name, package in _PKG_CONFIG
                    if subprocess.run(["pkg-config", "--exists", name], check=False,
                                      capture_output=True).returncode != 0]
    missing += [f"lib{name}.so ({package})" for name, package in _SHARED_LIBS
                if ctypes.util.find_library(name) is None]
    if not (FIRMWARE_DIR / "Makefile").exists():
        missing.append(f"{FIRMWARE_DIR}/Makefile (this checkout)")
    if missing:
        return ("cannot build/emulate the firmware, missing: " + ", ".join(dict.fromkeys(missing))
                + " (scripts/bootstrap --test installs them)")
    return None


async def build_firmware() -> tuple[Path, Path]:
    """Runs ``make -C firmware`` (a no-op when up to date); returns (elf, harness).

    A file lock serialises concurrent builds from parallel test sessions.
    """
    reason = missing_toolchain()
    if reason is not None:
        raise SimavrUnavailable(reason)
    (FIRMWARE_DIR / "build").mkdir(exist_ok=True)
    proc = await asyncio.create_subprocess_exec(
        "flock", str(FIRMWARE_DIR / "build" / ".lock"), "make", "-s", "-C", str(FIRMWARE_DIR),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT)
    out, _ = await proc.communicate()
    text = out.decode(errors="replace")
    if proc.returncode != 0:
        msg = f"firmware build failed (make -C {FIRMWARE_DIR}):\n{text[-2000:]}"
        raise SimavrUnavailable(msg)
    for line in text.splitlines():
        if line.startswith("firmware:"):
            log.info("simavr.built", size=line.removeprefix("firmware: "))
    return ELF_PATH, HARNESS_PATH


@dataclass(frozen=True, slots=True)
class McuPins:
    """The board's outputs at emulated time ``t_us``, as the harness read them."""

    t_us: int
    pwm_l: int  # duty 0-255 on ENA (D5)
    pwm_r: int  # duty 0-255 on ENB (D6)
    in_l: str  # IN1 IN2 levels: "10" forward, "01" reverse, "00" coast
    in_r: str
    servo_us: int  # pulse width on D9, 0 when the servo gets no pulse
    servo_period_us: int
    leds: int  # bit 0 left eye, 1 right eye, 2 green, 3 red
    evac: int = 0  # the station's suction signal (EVAC), through the 74HC595

    @classmethod
    def parse(cls, line: str) -> McuPins:
        fields = dict(item.split("=", 1) for item in line.split()[1:])
        return cls(t_us=int(fields["t_us"]), pwm_l=int(fields["pwm_l"]),
                   pwm_r=int(fields["pwm_r"]), in_l=fields["in_l"], in_r=fields["in_r"],
                   servo_us=int(fields["servo_us"]),
                   servo_period_us=int(fields["servo_period_us"]), leds=int(fields["leds"]),
                   evac=int(fields.get("evac", "0")))

    @property
    def drive(self) -> tuple[int, int, bool, bool]:
        """What the H-bridge does: (left duty, right duty, left forward, right forward)."""
        left = self.pwm_l if self.in_l in ("10", "01") else 0
        right = self.pwm_r if self.in_r in ("10", "01") else 0
        return left, right, self.in_l != "01", self.in_r != "01"

    @property
    def servo_deg(self) -> int | None:
        if self.servo_us == 0:
            return None
        span = SERVO_MAX_US - SERVO_MIN_US
        return round((self.servo_us - SERVO_MIN_US) * 180 / span)


def ir_millivolts(range_cm: float) -> int:
    """The Sharp sensor's output voltage for a range, per the firmware's conversion."""
    cm = min(150.0, max(20.0, range_cm))
    adc = IR_K / cm + IR_ADC_OFFSET
    return round(adc * ADC_REF_MV / 1023)


def counts_mv(counts: float) -> int:
    """The millivolts the 10-bit ADC reads as ``counts`` (the middle of that count's step)."""
    return round((counts + 0.5) * ADC_REF_MV / 1023)


class SimavrMcu:
    """One emulated motor board: the firmware on simavr, its UART pty and its pins."""

    def __init__(self, proc: asyncio.subprocess.Process, uart_path: str,
                 history: int = 10_000, workdir: tempfile.TemporaryDirectory[str] | None = None,
                 ) -> None:
        self._proc = proc
        self._workdir = workdir
        self.uart_path = uart_path
        self.pins: McuPins | None = None
        self.events: deque[McuPins] = deque(maxlen=history)
        self._replies: asyncio.Queue[str] = asyncio.Queue()
        self._listeners: list[Callable[[McuPins], None]] = []
        self._command_lock = asyncio.Lock()
        self._changed = asyncio.Event()
        self._reader = asyncio.get_running_loop().create_task(self._read_events())

    @classmethod
    async def start(cls, elf: Path | None = None, harness: Path | None = None) -> SimavrMcu:
        """Builds if needed, starts the harness and waits until the MCU runs.

        Raises:
            SimavrUnavailable: no toolchain/simavr, a failed build, or a harness that died.
        """
        if elf is None or harness is None:
            built_elf, built_harness = await build_firmware()
            elf, harness = elf or built_elf, harness or built_harness
        # A stable name for the pty (a symlink, like a udev rule), so unplug/replug keeps it.
        workdir = tempfile.TemporaryDirectory(prefix="robotd-simavr-")
        link = str(Path(workdir.name) / "ttyMCU")
        proc = await asyncio.create_subprocess_exec(
            str(harness), str(elf), "--link", link, stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
        assert proc.stdout is not None
        first = (await proc.stdout.readline()).decode().strip()
        ready = (await proc.stdout.readline()).decode().strip()
        if not first.startswith("UART ") or ready != "READY":
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
            await proc.wait()
            workdir.cleanup()
            msg = f"simavr harness did not start: {first!r} {ready!r}"
            raise SimavrUnavailable(msg)
        mcu = cls(proc, first.split(" ", 1)[1], workdir=workdir)
        log.info("simavr.started", uart=mcu.uart_path, pid=proc.pid)
        return mcu

    @property
    def pid(self) -> int:
        """The harness process (for CPU accounting)."""
        return self._proc.pid

    async def __aenter__(self) -> SimavrMcu:
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None,
                        exc: BaseException | None, tb: TracebackType | None) -> None:
        await self.close()

    async def _read_events(self) -> None:
        assert self._proc.stdout is not None
        while line := (await self._proc.stdout.readline()).decode():
            if line.startswith("EV "):
                self.pins = McuPins.parse(line)
                self.events.append(self.pins)
                self._changed.set()
                for listener in self._listeners:
                    listener(self.pins)
            elif line.split()[:2] in _FAULT_REPLIES:
                pass  # answers to the fire-and-forget fault switches
            else:
                self._replies.put_nowait(line.strip())
        self._replies.put_nowait("")  # the harness exited: wake a waiting command

    async def command(self, line: str, timeout_s: float = 5.0) -> str:
        """Sends one control-channel command and returns its reply line."""
        assert self._proc.stdin is not None
        async with self._command_lock:
            if self._proc.returncode is not None:
                msg = "simavr harness has exited"
                raise SimavrUnavailable(msg)
            self._proc.stdin.write(line.encode() + b"\n")
            await self._proc.stdin.drain()
            # asyncio.timeout, not wait_for: 3.11's wait_for can swallow a cancellation that
            # races with the reply, and a cancelled SimavrBridge would then run on.
            async with asyncio.timeout(timeout_s):
                reply = await self._replies.get()
        if not reply or reply.startswith("ERR"):
            msg = f"harness command {line!r} failed: {reply or 'harness exited'}"
            raise SimavrUnavailable(msg)
        return reply

    async def state(self) -> McuPins:
        return McuPins.parse(await self.command("STATE"))

    async def time_us(self) -> int:
        reply = await self.command("TIME")
        return int(dict(f.split("=") for f in reply.split()[1:])["t_us"])

    async def inject_encoder(self, left_ticks: int, right_ticks: int) -> None:
        """Queues quadrature edges; the harness emits one transition per wheel every 50 us."""
        await self.command(f"ENC {left_ticks} {right_ticks}")

    async def encoder_stats(self) -> dict[str, int]:
        """The harness's signed encoder totals since start: ``queued_l/r`` (asked by ENC),
        ``played_l/r`` (transitions made on the pins) and ``overridden_l/r`` (steps that found
        a pin not at the level the harness drove: should stay 0)."""
        reply = await self.command("ENCSTAT")
        return {k: int(v) for k, v in (f.split("=") for f in reply.split()[1:])}

    async def set_adc_mv(self, channel: int, millivolts: int) -> None:
        await self.command(f"ADC {channel} {millivolts}")

    async def set_range_cm(self, range_cm: float) -> None:
        await self.set_adc_mv(ADC_IR, ir_millivolts(range_cm))

    async def set_battery_v(self, voltage_v: float) -> None:
        await self.set_adc_mv(ADC_BATTERY, round(voltage_v * 1000 / BATTERY_DIVIDER))

    async def set_dock(self, on_dock: bool) -> None:
        """A charger on the contacts (16.8 V) or none."""
        await self.command(f"DOCK {int(on_dock)}")

    async def set_mux_mv(self, channel: int, millivolts: int) -> None:
        """The voltage on one input of the board's docking multiplexer."""
        await self.command(f"MUX {channel} {millivolts}")

    async def set_contact_mv(self, contact_mv: int) -> None:
        await self.set_mux_mv(MUX_CONTACTS, round(contact_mv / CONTACT_DIVIDER))

    async def set_dock_signal(self, front_left: int, front_right: int) -> None:
        """The front receivers' strength as the 10-bit counts the firmware should read."""
        for channel, counts in ((MUX_IRS_L, front_left), (MUX_IRS_R, front_right)):
            await self.set_mux_mv(channel, counts_mv(counts))

    async def set_bumpers(self, left: bool, right: bool) -> None:
        await self.set_mux_mv(MUX_BUMP_L, ADC_REF_MV if left else 0)
        await self.set_mux_mv(MUX_BUMP_R, ADC_REF_MV if right else 0)

    async def set_wall_cm(self, wall_cm: float) -> None:
        cm = min(30.0, max(4.0, wall_cm))
        await self.set_mux_mv(MUX_WALL, counts_mv(WALL_K / cm + WALL_ADC_OFFSET))

    async def set_bin_pct(self, bin_pct: float) -> None:
        pct = min(100.0, max(0.0, bin_pct))
        await self.set_mux_mv(MUX_BIN, round(BIN_EMPTY_MV + pct * (BIN_FULL_MV - BIN_EMPTY_MV)
                                             / 100))

    async def loop_stats(self, reset: bool = False) -> dict[str, float]:
        """The firmware's main-loop period in emulated time (min/p50/p99/max/mean, us)."""
        reply = await self.command("LOOP")
        if reset:
            await self.command("LOOPRESET")
        return {k: float(v) for k, v in (f.split("=") for f in reply.split()[1:])}

    def add_listener(self, listener: Callable[[McuPins], None]) -> None:
        """Calls listener with every new pin sample, as soon as it is read."""
        self._listeners.append(listener)

    # Fault switches, like a technician's hands: they take effect within a millisecond and
    # need no await, so a test can time them with loop.time().
    def corrupt(self, pct: float) -> None:
        """Corrupts pct % of the UART bytes, both directions."""
        self._send_nowait(f"CORRUPT {pct}")

    def delay(self, seconds: float) -> None:
        """Holds every byte the MCU sends this long (a slow USB adapter or host)."""
        self._send_nowait(f"DELAY {seconds}")

    def unplug(self) -> None:
        """Pulls the USB cable: the port vanishes (reads fail) until replug(); the MCU runs on."""
        self._send_nowait("UNPLUG")

    def replug(self) -> None:
        self._send_nowait("REPLUG")

    def reset(self) -> None:
        """Resets the MCU, as its reset button (or a DTR pulse) does."""
        self._send_nowait("RESET")

    def _send_nowait(self, line: str) -> None:
        assert self._proc.stdin is not None
        self._proc.stdin.write(line.encode() + b"\n")

    async def wait_for(self, predicate: Callable[[McuPins], bool],
                       timeout_s: float = 5.0) -> McuPins:
        """Waits until the pins satisfy predicate (checks the current state first)."""
        async with asyncio.timeout(timeout_s):
            while True:
                self._changed.clear()
                if self.pins is not None and predicate(self.pins):
                    return self.pins
                await self._changed.wait()

    async def close(self) -> None:
        if self._proc.returncode is None:
            assert self._proc.stdin is not None
            with contextlib.suppress(BrokenPipeError, ConnectionResetError):
                self._proc.stdin.write(b"QUIT\n")
                await self._proc.stdin.drain()
            try:
                async with asyncio.timeout(2.0):
                    await self._proc.wait()
            except TimeoutError:
                self._proc.kill()
                await self._proc.wait()
        await cancel_and_wait(self._reader)
        if self._workdir is not None:
            self._workdir.cleanup()
        log.info("simavr.stopped", uart=self.uart_path)


async def _serve() -> None:
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        asyncio.get_running_loop().add_signal_handler(sig, stop.set)
    async with await SimavrMcu.start() as mcu:
        print(f"firmware running on simavr; UART at {mcu.uart_path} (Ctrl-C stops)", flush=True)
        await stop.wait()


def main() -> None:
    """``python -m sim.devices.motor_board.simavr_mcu``: run the emulated board for a
    technician's tools."""
    reason = missing_toolchain()
    if reason is not None:
        raise SystemExit(reason)
    asyncio.run(_serve())


if __name__ == "__main__":
    main()
