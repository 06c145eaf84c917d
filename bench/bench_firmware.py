"""The motor-board firmware on an emulated ATmega328P (simavr): link latency and loop time.

    .venv/bin/python bench/bench_firmware.py [--count N]

Prints:
- command-to-ACK RTT p50/p99 over the emulated UART at 115200 baud, raw frames on the pty
  (`#SEQ HB*CC` -> `#SEQ ACK*CC`), next to the time the bytes alone need on the wire, and
  the same through the real driver (``ArduinoLink``, HB and MOTOR);
- the MCU main loop in emulated CPU cycles: busy time per iteration (work done before the
  firmware idles) and the period between iterations, idle and while commands stream in;
- the deadman in emulated time: last MOTOR to PWM 0 on the pins, over a few trials;
- what the emulator costs the host: CPU share of one core while it keeps wall-clock pace.
The emulator runs in wall time, so figures include this machine's scheduling noise.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import sys
from pathlib import Path

import structlog

from drivers.arduino import ArduinoLink, LinkConfig
from drivers.serial_port import open_serial
from hal.readings import MotorCommand
from sim.devices.motor_board.simavr_mcu import SimavrMcu, missing_toolchain

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "firmware"))
from firmware_client import PtyLink  # the tests' minimal framing helper

BAUD = 115200
BITS_PER_BYTE = 10  # 8N1


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _loop_line(label: str, stats: dict[str, float]) -> str:
    return (f"  {label:<22} busy p50 {stats['busy_p50_us']:.0f} us, p99 "
            f"{stats['busy_p99_us']:.0f} us, max {stats['busy_max_us']:.0f} us; period p50 "
            f"{stats['period_p50_us']:.0f} us, max {stats['period_max_us']:.0f} us "
            f"({stats['n']:.0f} iterations)")


async def raw_rtt(mcu: SimavrMcu, count: int) -> list[float]:
    link = PtyLink.open(mcu.uart_path)
    loop = asyncio.get_running_loop()
    rtts: list[float] = []
    try:
        for i in range(count):
            start = loop.time()
            body = await link.command(i % 256, "HB")
            rtts.append((loop.time() - start) * 1000)
            assert body == f"#{i % 256} ACK", body
    finally:
        link.close()
    return rtts


async def driver_rtt(mcu: SimavrMcu, count: int, payload: str) -> tuple[float, float, int]:
    link = ArduinoLink(open_serial, LinkConfig(port=mcu.uart_path))
    await link.start()
    try:
        for i in range(count):
            text = payload.format(i=i % 200)
            assert (await link.command(text)).ok
        stats = link.link_stats()
        return stats.rtt_p50_ms, stats.rtt_p99_ms, stats.lost
    finally:
        await link.close()


async def deadman_ms(mcu: SimavrMcu, trials: int) -> list[float]:
    link = ArduinoLink(open_serial, LinkConfig(port=mcu.uart_path, heartbeat_s=3600.0))
    await link.start()
    delays: list[float] = []
    try:
        for trial in range(trials):
            duty = 100 + trial
            await link.drive(MotorCommand(duty, duty))
            on = await mcu.wait_for(lambda p, d=duty: p.pwm_l == d)
            off = await mcu.wait_for(lambda p: p.pwm_l == 0, timeout_s=10.0)
            delays.append((off.t_us - on.t_us) / 1000)
    finally:
        await link.close()
    return delays


async def main(count: int) -> None:
    async with await SimavrMcu.start() as mcu:
        pid = mcu.pid
        await asyncio.sleep(1.0)
        await mcu.loop_stats(reset=True)
        cpu0, t0 = _cpu_s(pid), asyncio.get_running_loop().time()
        await asyncio.sleep(3.0)
        idle_cpu_pct = 100 * (_cpu_s(pid) - cpu0) / (asyncio.get_running_loop().time() - t0)
        idle = await mcu.loop_stats(reset=True)

        rtts = await raw_rtt(mcu, count)
        busy = await mcu.loop_stats(reset=True)
        wire_ms = (len(b"#123 HB*CC\n") + len(b"#123 ACK*CC\n")) * BITS_PER_BYTE / BAUD * 1000
        hb = await driver_rtt(mcu, count, "HB")
        motor = await driver_rtt(mcu, count, "MOTOR:{i},{i},1,0")
        delays = await deadman_ms(mcu, 5)

    print(f"firmware on simavr (ATmega328P 16 MHz, UART {BAUD} 8N1), {count} commands a case")
    print("command -> ACK RTT, wall clock:")
    print(f"  raw frames on the pty   p50 {_pct(rtts, 0.5):.2f} ms, p99 {_pct(rtts, 0.99):.2f} "
          f"ms; the bytes alone need {wire_ms:.2f} ms on the wire "
          f"(p50 = {_pct(rtts, 0.5) / wire_ms:.1f}x)")
    print(f"  driver, HB              p50 {hb[0]:.2f} ms, p99 {hb[1]:.2f} ms, lost {hb[2]}")
    print(f"  driver, MOTOR           p50 {motor[0]:.2f} ms, p99 {motor[1]:.2f} ms, "
          f"lost {motor[2]}")
    print("MCU main loop, emulated cycles (busy = work before idling; period includes idle):")
    print(_loop_line("idle (telemetry only)", idle))
    print(_loop_line("commands back to back", busy))
    print(f"deadman, last MOTOR to PWM 0 on the pins (emulated): "
          f"{min(delays):.1f}-{max(delays):.1f} ms over {len(delays)} trials (contract 500-600)")
    print(f"emulator cost: {idle_cpu_pct:.0f} % of one host core at wall-clock pace")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=500)
    args = parser.parse_args()
    reason = missing_toolchain()
    if reason is not None:
        raise SystemExit(f"bench_firmware: {reason}")
    structlog.configure(wrapper_class=structlog.make_filtering_bound_logger(logging.WARNING))
    asyncio.run(main(args.count))
