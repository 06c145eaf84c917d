"""CPU per second of real time and event-loop lag of each robot profile's daemon, idle and
mid-mission, beside a plain reference loop measured in the same run, and the factor to a
Raspberry Pi 4 (issue 31).

Each profile runs as the service does, ``robotd run --config GENERATED.toml``, a real process
on its real drivers, fed by ``python -m sim.feed SCENARIO`` in another process (whose CPU is not
counted) at real rates and in real time: the motor board (the fake MCU speaking the serial
protocol, its encoders turning with the commanded wheels, the docking lines) on a pty, the
LD19's byte stream (10 Hz, 4500 points/s, 47-byte packets, ~21 kB/s, ranges ray-cast in the
scenario's world at the robot's pose) on another pty, the dock IR receivers' edges, the BLE
adverts and the HX711's conversions on named pipes (``docking.ir_source``, ``ble.source``,
``hx711.source`` = ``"stream"``), the line camera and the QR camera from video files
(``camera.source``/``qr_camera.source = "file"``, MJPEG at the configured rate: the line
camera's is a still of what it sees at the start), sounds into ALSA's null device. The feeder
plays the scenario's script (a customer walking in), starting it ``--hold-s`` after the
daemon answers.

Every 0.25 s the bench reads the daemon's CPU time (/proc/PID/stat) and asks ``status`` for
the state and the loop monitor's latest lag (``loop_lag_ms.last_ms``; the monitor wakes every
0.25 s), and files the interval under the state it ended in: ``idle`` (idle or maintenance,
RelayBot waiting at home, a vacuum on its dock) or ``mission`` (anything else: moving,
docking, recovery);
``boot`` (loading maps, fitting the first scan) is shown apart. Start-up before the socket
answers is not counted. Once a robot has been ``--seconds`` mid-mission and has had no idle
time yet, the bench ends its mission as a technician would (``trigger mission_done``; if it
sets off again by itself, as the laundry robot's local route does, ``trigger maintenance``)
and measures it idle. A profile that cannot be fed says why, and its ``robotd sim --realtime``
figure (an upper bound, below) is measured in its place.

The reference is a plain asyncio process running only robotd's loop monitor (same timer
chain, same 0.25 s period): the floor of CPU and lag on this machine at this moment (the
machine is shared, so both move together).

``--upper-bound`` adds the older rows: each profile in ``robotd sim SCENARIO --realtime`` (the
simulated world in the daemon's own process: an upper bound), and ``robotd run`` idle and
square with only the motor board on a pty (the fake board's encoders do not turn there).

The Pi 4 factor is measured too: the Computer Language Benchmarks Game's n-body in pure
Python, 500 000 steps here (CPU time), against 5 000 000 steps in 158.3 s on a Raspberry
Pi 4 Model B (Cortex-A72 at 1.5 GHz, performance governor; C. Mehta, "Performance Analysis
of Languages on Raspberry Pi", chaitanyamehta.github.io). Python there was Raspberry Pi OS's
of 2020 (3.7), slower than 3.11 by about a quarter on such code, so the factor overstates
the Pi's cost by about that much: a margin, not an error.

``--steps-ms MS`` runs each daemon with ``ROBOTD_STEP_CPU_MS=MS`` (``robotd/step_cpu.py``) and
lists, per profile, the loop steps that took more than MS of the loop thread's CPU time, named
by their task: what holds the loop, apart from the machine's other work.

    .venv/bin/python bench/bench_cpu_budget.py [--profiles delivery,cabinet] [--seconds 25]
                                               [--steps-ms 2]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from robotd.ctl.connection import CannotConnect, Connection, DaemonError  # noqa: E402

SCENARIOS = {"laundry": "laundry-loop", "vacuum": "docking", "delivery": "delivery",
             "cabinet": "cabinet"}
PERIOD_S = 0.25
PI4_NBODY_S = 158.263  # 5e6 steps, Pi 4 Model B at 1.5 GHz, performance governor
PI4_NBODY_STEPS = 5_000_000
NBODY_STEPS = 500_000
TARGET_DELIVERY_CPU_PCT = 10.0
TARGET_LAG_P99_MS = 5.0

REFERENCE = """
import asyncio, json, sys
from robotd.health import LoopMonitor

async def main(seconds):
    monitor = LoopMonitor(lambda: 1e9)
    task = asyncio.create_task(monitor.run(lambda: None))
    print("ready", flush=True)
    await asyncio.sleep(seconds)
    task.cancel()
    print(json.dumps(list(monitor._lags_ms)), flush=True)

asyncio.run(main(float(sys.argv[1])))
"""


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(samples: list[float], pct: float) -> float:
    ordered = sorted(samples)
    if not ordered:
        return float("nan")
    index = max(0, min(len(ordered) - 1, round(pct / 100 * len(ordered) + 0.5) - 1))
    return ordered[index]


@dataclass
class Phase:
    """CPU seconds, wall seconds and lag samples of the intervals in one state class."""

    cpu_s: float = 0.0
    wall_s: float = 0.0
    lags_ms: list[float] = field(default_factory=list)
    states: set[str] = field(default_factory=set)
    worst: list[tuple[float, float, str]] = field(default_factory=list)
    """The three longest lags: (lag ms, seconds since the window opened, state)."""

    @property
    def cpu_pct(self) -> float:
        return 100 * self.cpu_s / self.wall_s if self.wall_s else float("nan")


# Not moving, waiting for work: RelayBot waits at home inside its mission; a vacuum docked.
RESTING = ("mission.waiting", "docking.charging", "docking.standby")


def state_class(state: str) -> str:
    root = state.split(".", maxsplit=1)[0]
    if root == "boot":
        return "boot"
    return "idle" if root in ("idle", "maintenance") or state in RESTING else "mission"


Step = Callable[[Connection, dict[str, "Phase"], str, float], bool]
"""Called after each interval with (connection, phases so far, state, seconds since the
window opened); True ends the measurement."""


def for_seconds(seconds: float) -> Step:
    return lambda _conn, _phases, _state, elapsed: elapsed >= seconds


def idle_and_mission(seconds: float, notes: list[str]) -> Step:
    """Until the robot has been ``seconds`` idle and ``seconds`` mid-mission (at most four
    times that in all). A robot mid-mission for long enough is sent idle (``mission_done``);
    one that starts its next mission from idle by itself (a local route's loop) is then put
    in ``maintenance``: parked, its devices running, which counts as idle."""
    sent: list[str] = []

    def step(conn: Connection, phases: dict[str, Phase], state: str, elapsed: float) -> bool:
        idle_s = phases["idle"].wall_s if "idle" in phases else 0.0
        mission_s = phases["mission"].wall_s if "mission" in phases else 0.0
        left = [t for t in ("mission_done", "maintenance") if t not in sent]
        if mission_s >= seconds and idle_s < seconds and left \
                and state_class(state) == "mission":
            sent.append(left[0])
            try:
                conn.call("trigger", {"name": left[0]})
                notes.append(f"{left[0]} sent by the bench in {state}")
            except DaemonError as exc:
                notes.append(f"{left[0]} refused in {state}: {exc}")
        return (idle_s >= seconds and mission_s >= seconds) or elapsed >= 4 * seconds

    return step


def measure_fed(profile: str, seconds: float, notes: list[str], steps_ms: float = 0.0
                ) -> tuple[dict[str, Phase], dict[str, Any], dict[str, Any]]:
    """``robotd run`` on its real drivers, fed by ``python -m sim.feed`` in its own process;
    also the feeder's figures (what its devices sent)."""
    with tempfile.TemporaryDirectory(prefix="bcpu-") as tmp:
        work = Path(tmp)
        feed = subprocess.Popen(
            [sys.executable, "-m", "sim.feed", SCENARIOS[profile], "--dir", str(work / "feed"),
             "--hold-s", str(seconds)], stdout=subprocess.PIPE, text=True, cwd=ROOT)
        figures: dict[str, Any] = {}
        try:
            assert feed.stdout is not None
            line = feed.stdout.readline().strip()
            if not line.startswith("config "):
                msg = (f"python -m sim.feed {SCENARIOS[profile]} did not start "
                       f"({line or 'no output'})")
                raise NoDaemon(msg)
            config = line.removeprefix("config ")
            argv = [str(Path(sys.executable).with_name("robotd")), "run", "--config", config]
            phases, status = measure_process(argv, str(work / "feed" / "control.sock"), work,
                                             idle_and_mission(seconds, notes), steps_ms)
        finally:
            feed.send_signal(signal.SIGINT)
            try:
                out, _ = feed.communicate(timeout=15)
                last = out.strip().splitlines()[-1:] if out else []
                figures = json.loads(last[0]) if last and last[0].startswith("{") else {}
            except subprocess.TimeoutExpired:
                feed.kill()
                feed.wait()
        return phases, status, figures


def measure_profile(profile: str, seconds: float) -> tuple[dict[str, Phase], dict[str, Any]]:
    """``robotd sim SCENARIO --realtime``: the profile's daemon with its simulated world."""
    with tempfile.TemporaryDirectory(prefix="bcpu-") as tmp:
        sock = str(Path(tmp) / "c.sock")
        argv = [str(Path(sys.executable).with_name("robotd")), "sim", SCENARIOS[profile],
                "--realtime", "--socket", sock, "--quiet"]
        return measure_process(argv, sock, Path(tmp), for_seconds(seconds))


def measure_run(profile: str, seconds: float) -> tuple[dict[str, Phase], dict[str, Any]]:
    """``robotd run`` alone (no simulator in its process) with the real Arduino driver on a
    pty, served at real rates by the fake motor board in a process of its own."""
    with tempfile.TemporaryDirectory(prefix="bcpu-") as tmp:
        work = Path(tmp)
        board = subprocess.Popen(
            [sys.executable, "-m", "sim.devices.motor_board.pty_mcu", "--link",
             str(work / "ttyACM0")], stdout=subprocess.PIPE, text=True, cwd=ROOT)
        try:
            assert board.stdout is not None
            port = board.stdout.readline().strip()
            sock = str(work / "c.sock")
            config = work / "robotd.toml"
            config.write_text(f'[robot]\nprofile = "{profile}"\nstate_dir = "{work / "state"}"\n'
                              f'[control]\nsocket = "{sock}"\n[hal]\ndevices = ["motors"]\n'
                              f'[serial]\nport = "{port}"\n')
            argv = [str(Path(sys.executable).with_name("robotd")), "run", "--config",
                    str(config)]
            return measure_process(argv, sock, work, for_seconds(seconds))
        finally:
            board.send_signal(signal.SIGINT)
            try:
                board.wait(10)
            except subprocess.TimeoutExpired:
                board.kill()
                board.wait()


def measure_process(argv: list[str], sock: str, work: Path, done: Step, steps_ms: float = 0.0
                    ) -> tuple[dict[str, Phase], dict[str, Any]]:
    errors = work / "stderr"
    env = {**os.environ, "ROBOTD_STEP_CPU_MS": str(steps_ms) if steps_ms > 0 else ""}
    with errors.open("w") as err:
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=err, cwd=work, env=env)
    try:
        conn = _connect(sock, proc, errors)
        phases: dict[str, Phase] = {}
        last_status: dict[str, Any] = {}
        t_prev, cpu_prev = time.monotonic(), cpu_s(proc.pid)
        t_open = t_prev
        while proc.poll() is None:
            time.sleep(max(0.0, PERIOD_S - (time.monotonic() - t_prev)))
            try:
                last_status = conn.call("status")
                now, cpu = time.monotonic(), cpu_s(proc.pid)
            except (CannotConnect, FileNotFoundError, ProcessLookupError):
                break  # the scenario ended
            state = last_status["state"]
            phase = phases.setdefault(state_class(state), Phase())
            phase.cpu_s += cpu - cpu_prev
            phase.wall_s += now - t_prev
            lag_ms = float(last_status["loop_lag_ms"]["last_ms"])
            phase.lags_ms.append(lag_ms)
            phase.worst = sorted([*phase.worst, (lag_ms, now - t_open, state)])[-3:]
            phase.states.add(state.split(".")[1] if state.startswith("mission.")
                             and state_class(state) == "mission" else state)
            t_prev, cpu_prev = now, cpu
            if done(conn, phases, state, now - t_open):
                break
        conn.close()
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
    return phases, last_status


class NoDaemon(Exception):
    """The profile's process did not come up; the message says why."""


def _connect(sock: str, proc: subprocess.Popen[bytes], errors: Path) -> Connection:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            why = [line for line in errors.read_text().splitlines()
                   if line and not line.startswith("{")]
            command = f"{Path(str(proc.args[0])).name} {proc.args[1]}"  # type: ignore[index]
            msg = (f"{command} exited ({proc.returncode}) before its socket answered: "
                   f"{why[-1] if why else '-'}")
            raise NoDaemon(msg)
        try:
            conn = Connection(sock, 5.0)
            conn.call("status")
            return conn
        except (CannotConnect, FileNotFoundError):
            time.sleep(0.1)
    msg = f"no answer on {sock} within 60 s"
    raise NoDaemon(msg)


def measure_reference(seconds: float) -> Phase:
    proc = subprocess.Popen([sys.executable, "-c", REFERENCE, str(seconds)],
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    t0, cpu0 = time.monotonic(), cpu_s(proc.pid)
    lags_line = proc.stdout.readline()
    t1, cpu1 = time.monotonic(), cpu_s(proc.pid)
    proc.wait(10)
    return Phase(cpu1 - cpu0, t1 - t0, json.loads(lags_line))


def nbody_s(steps: int) -> float:
    """The Benchmarks Game's n-body (pure Python), ``steps`` steps: CPU seconds taken (CPU,
    not wall: this machine is shared, the Pi's figure was taken on an idle board)."""
    pi, days = 3.14159265358979323, 365.24
    solar_mass = 4 * pi * pi
    bodies = [
        [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], solar_mass],
        [[4.84143144246472090e00, -1.16032004402742839e00, -1.03622044471123109e-01],
         [1.66007664274403694e-03 * days, 7.69901118419740425e-03 * days,
          -6.90460016972063023e-05 * days], 9.54791938424326609e-04 * solar_mass],
        [[8.34336671824457987e00, 4.12479856412430479e00, -4.03523417114321381e-01],
         [-2.76742510726862411e-03 * days, 4.99852801234917238e-03 * days,
          2.30417297573763929e-05 * days], 2.85885980666130812e-04 * solar_mass],
        [[1.28943695621391310e01, -1.51111514016986312e01, -2.23307578892655734e-01],
         [2.96460137564761618e-03 * days, 2.37847173959480950e-03 * days,
          -2.96589568540237556e-05 * days], 4.36624404335156298e-05 * solar_mass],
        [[1.53796971148509165e01, -2.59193146099879641e01, 1.79258772950371181e-01],
         [2.68067772490389322e-03 * days, 1.62824170038242295e-03 * days,
          -9.51592254519715870e-05 * days], 5.15138902046611451e-05 * solar_mass]]
    pairs = [(bodies[i], bodies[j]) for i in range(5) for j in range(i + 1, 5)]
    start = time.process_time()
    dt = 0.01
    for _ in range(steps):
        for ([x1, y1, z1], v1, m1), ([x2, y2, z2], v2, m2) in pairs:
            dx, dy, dz = x1 - x2, y1 - y2, z1 - z2
            mag = dt * ((dx * dx + dy * dy + dz * dz) ** -1.5)
            b1m, b2m = m1 * mag, m2 * mag
            v1[0] -= dx * b2m
            v1[1] -= dy * b2m
            v1[2] -= dz * b2m
            v2[0] += dx * b1m
            v2[1] += dy * b1m
            v2[2] += dz * b1m
        for r, [vx, vy, vz], _m in bodies:
            r[0] += dt * vx
            r[1] += dt * vy
            r[2] += dt * vz
    return time.process_time() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--profiles", default="laundry,vacuum,delivery,cabinet",
                        help="comma-separated, of: " + ", ".join(SCENARIOS))
    parser.add_argument("--seconds", type=float, default=25.0,
                        help="real seconds measured per state class and profile (and for the "
                             "reference)")
    parser.add_argument("--steps-ms", type=float, default=0.0,
                        help="also list the daemon's loop steps that took more CPU than this "
                             "(ROBOTD_STEP_CPU_MS; the timing adds a little CPU)")
    parser.add_argument("--upper-bound", action="store_true",
                        help="also the robotd sim --realtime rows and robotd run idle/square")
    args = parser.parse_args()
    profiles = [p for p in args.profiles.split(",") if p]
    unknown = [p for p in profiles if p not in SCENARIOS]
    if unknown:
        parser.error(f"--profiles: unknown {', '.join(unknown)} (known: {', '.join(SCENARIOS)})")

    print(f"load average at the start: {' '.join(Path('/proc/loadavg').read_text().split()[:3])}"
          f", {os.cpu_count()} CPUs")
    here_s = nbody_s(NBODY_STEPS)
    factor = (PI4_NBODY_S / PI4_NBODY_STEPS) / (here_s / NBODY_STEPS)
    print(f"Pi 4 factor: n-body {NBODY_STEPS} steps {here_s:.2f} s here; Pi 4 "
          f"{PI4_NBODY_S / PI4_NBODY_STEPS * NBODY_STEPS:.2f} s -> x{factor:.1f}")
    print(f"{'what':34} {'state':8} {'cpu %':>7} {'Pi4 %':>7} {'lag p50':>8} "
          f"{'lag p99':>8} {'lag max':>8} {'n':>4}  states")

    def row(what: str, state: str, phase: Phase) -> None:
        lags = phase.lags_ms
        print(f"{what:34} {state:8} {phase.cpu_pct:7.1f} {phase.cpu_pct * factor:7.1f} "
              f"{percentile(lags, 50):8.2f} {percentile(lags, 99):8.2f} "
              f"{max(lags, default=float('nan')):8.2f} {len(lags):4d}  "
              f"{','.join(sorted(phase.states))[:40]}")

    reference = measure_reference(args.seconds)
    row("reference: asyncio + loop monitor", "-", reference)
    verdicts = []
    for profile in profiles:
        notes: list[str] = []
        what = f"{profile}: robotd run, fed"
        try:
            phases, status, figures = measure_fed(profile, args.seconds, notes, args.steps_ms)
        except NoDaemon as exc:
            print(f"{what}: not measured: {exc}")
            verdicts.append(f"{profile}: robotd run not measured")
            if not args.upper_bound:  # its simulation's figure, an upper bound, instead
                upper_bound_rows([profile], args.seconds, row, daemon_alone=False)
            continue
        for state in ("boot", "idle", "mission"):
            if state not in phases:
                continue
            phase = phases[state]
            row(what, state, phase)
            p99 = percentile(phase.lags_ms, 99)
            if state != "boot" and p99 > TARGET_LAG_P99_MS:
                verdicts.append(f"{profile} {state}: lag p99 {p99:.1f} ms > "
                                f"{TARGET_LAG_P99_MS} ms")
            if profile == "delivery" and state != "boot" \
                    and phase.cpu_pct > TARGET_DELIVERY_CPU_PCT:
                verdicts.append(f"delivery {state}: {phase.cpu_pct:.1f} % of a core here > "
                                f"{TARGET_DELIVERY_CPU_PCT} %")
        print(f"{'':34} feeder: {json.dumps(figures)}; {'; '.join(notes) or '-'}")
        worst = sorted((w for p in phases.values() for w in p.worst), reverse=True)[:3]
        print(f"{'':34} longest lags: " + ", ".join(
            f"{lag:.1f} ms at {t:.1f} s in {state}" for lag, t, state in worst))
        if args.steps_ms > 0:
            print_slow_steps(status.get("slow_steps", {}))
    if args.upper_bound:
        upper_bound_rows(profiles, args.seconds, row)
    print("targets: delivery <= 10 % of a core here, every lag p99 <= 5 ms: "
          + ("met" if not verdicts else "not met: " + "; ".join(verdicts)))
    return 0


def print_slow_steps(slow: dict[str, Any]) -> None:
    """The daemon's loop steps over ``--steps-ms`` of CPU, over its whole run."""
    steps = slow.get("steps", {})
    print(f"{'':34} steps over {slow.get('threshold_ms', '?')} ms of CPU: "
          f"{'none' if not steps else ''}")
    for name, f in list(steps.items())[:12]:
        print(f"{'':36} {f['count']:5d} x, {f['cpu_ms']:8.1f} ms CPU, max {f['max_cpu_ms']:6.1f}"
              f" ms CPU / {f['max_wall_ms']:6.1f} ms wall  {name}")


def upper_bound_rows(profiles: list[str], seconds: float,
                     row: Callable[[str, str, Phase], None], *, daemon_alone: bool = True
                     ) -> None:
    """The simulated world in the daemon's process, and the daemon with only its motor board."""
    for profile in ("idle", "square") if daemon_alone else ():  # no simulated world in it
        try:
            phases, _status = measure_run(profile, seconds)
        except NoDaemon as exc:
            print(f"robotd run {profile}: not measured: {exc}")
            continue
        for state, phase in sorted(phases.items()):
            row(f"robotd run {profile} (board on pty)", state, phase)
    for profile in profiles:
        try:
            phases, _status = measure_profile(profile, seconds)
        except NoDaemon as exc:
            print(f"{profile} (sim {SCENARIOS[profile]}): not measured: {exc}")
            continue
        for state, phase in sorted(phases.items()):
            row(f"{profile} (sim {SCENARIOS[profile]} --realtime)", state, phase)


if __name__ == "__main__":
    sys.exit(main())
