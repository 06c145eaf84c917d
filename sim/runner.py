"""``robotd sim``: the real daemon, state machine, behaviours and drivers on a simulated world.

The runner builds the world and one body per robot from a scenario, the simulated devices
(fakes at the lowest layer, the real drivers on top), and a ``Daemon`` per robot; it plays the
scenario's script, watches the success conditions, and writes the report.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import functools
import math
import random
import signal
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import structlog

from hal.looptime.timer_chain import timer_chain
from robotd.config import ConfigError
from robotd.config.settings import Settings
from robotd.control.access import socket_problem
from robotd.logs import configure_logging
from robotd.profiles import PROFILES
from robotd.viz.runtime import telemetry_of
from robotd.viz.session import VizError, VizSession
from sim import vclock
from sim.actors import ActorContext, SimActors, actors_factory
from sim.checks import RobotRecord, failures, finished, summary_figures
from sim.config import robot_settings
from sim.console import SimConsole
from sim.crash import DaemonKeeper
from sim.process_tuning import simulator_process
from sim.registry import slice_of
from sim.report import draw_trajectory, write_events
from sim.rig import SimRig, open_sim_rig
from sim.scenario import RobotSpec, Scenario, ScenarioError, load_scenario
from sim.script import ScriptPlayer
from sim.tracks import PathRecorder, TrackPoint
from sim.viz_feed import SimFeed, open_sim_viz
from sim.world.body import Collision, DiffDriveBody
from sim.world.geometry import Pose

log = structlog.get_logger(__name__)

SIM_EPOCH = datetime(2026, 1, 1, tzinfo=UTC)
"""Wall-clock time at virtual t=0, so reports do not depend on when they were made."""

_WATCH_PERIOD_S = 0.1
REPORT_FILES = ("events.jsonl", "trajectory.png", "run.mcap")
_STOP_TIMEOUT_S = 10.0


@dataclass
class SimRobot:
    spec: RobotSpec
    settings: Settings
    body: DiffDriveBody
    rig: SimRig
    daemon: Any
    record: RobotRecord
    socket_path: str


def run_sim(args: argparse.Namespace) -> int:
    """``robotd sim`` (sim.command): returns the exit code (0 success, 1 failure, 2 bad input)."""
    console = SimConsole(quiet=bool(getattr(args, "quiet", False)), from_process_start=True)
    try:
        scenario = load_scenario(args.scenario)
    except ScenarioError as exc:
        print(f"robotd sim: {exc}")
        return 2
    speed: float | None = None
    if getattr(args, "realtime", False):
        speed = 1.0
    elif getattr(args, "speed", None) is not None:
        speed = float(args.speed)
    report_dir = getattr(args, "report", None)
    if report_dir:
        try:
            Path(report_dir).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            print(f"robotd sim: --report {report_dir}: cannot create the directory: "
                  f"{exc.strerror or exc}")
            return 2
        links = [n for n in REPORT_FILES if (Path(report_dir) / n).is_symlink()]
        if links:  # another user's link would have us write where they chose
            print(f"robotd sim: --report {report_dir}: {', '.join(links)} is a symbolic "
                  f"link: not written through it (remove it)")
            return 2
    # The robots' state stores, control sockets and the fleet database live here for the run.
    with tempfile.TemporaryDirectory(prefix="robotd-sim-") as workdir:
        started = time.perf_counter()
        result = vclock.run(_run(args, scenario, console, Path(workdir)), speed=speed)
        run_wall_s = time.perf_counter() - started
    if isinstance(result, int):
        return result
    return _report(args, scenario, result, console, run_wall_s)


async def _run(args: argparse.Namespace, scenario: Scenario, console: SimConsole,
               workdir: Path) -> SimResult | int:
    with simulator_process():  # OpenCV on one thread, a lazier collector (process_tuning.py)
        return await _simulate(args, scenario, console, workdir)


async def _simulate(args: argparse.Namespace, scenario: Scenario, console: SimConsole,
                    workdir: Path) -> SimResult | int:
    from robotd.daemon import Daemon

    loop = asyncio.get_running_loop()
    seed = int(args.seed) if getattr(args, "seed", None) is not None else \
        int(scenario.raw.get("scenario", {}).get("seed", 1))
    events: list[dict[str, Any]] = []
    player: ScriptPlayer | None = None
    many = len(scenario.robots) > 1
    robots: dict[str, SimRobot] = {}

    # Virtual runs use a fixed epoch so their reports repeat; wall-clock runs use real time.
    origin = SIM_EPOCH if getattr(loop, "virtual", True) else \
        datetime.now(UTC) - timedelta(seconds=loop.time())

    def wall_clock() -> datetime:
        return origin + timedelta(seconds=loop.time())

    # --quiet prints the result only: the daemons' warnings (link.down as a robot shuts down...)
    # are in events.jsonl's story already; a crash still shows its traceback.
    configure_logging("critical" if console.quiet else "warning",
                      mode="console" if console.tty else "json",
                      timestamper=lambda: wall_clock().isoformat())

    def on_event(robot: str, event: dict[str, Any]) -> None:
        record = robots[robot].record if robot in robots else None
        entry = dict(event)
        entry.setdefault("t", loop.time())
        if many and robot:
            entry["robot"] = robot
        if record is not None and "x_m" not in entry and entry.get("kind") != "service":
            pose = record.body.pose
            entry["x_m"], entry["y_m"] = pose.x_m, pose.y_m
            if str(entry.get("kind", "")).startswith(("nav.", "mapping.")):  # the truth
                entry["true_heading_deg"] = round(math.degrees(pose.heading_rad), 2)
        if record is not None and entry.get("kind") == "transition":
            dst = str(entry.get("dst", ""))
            record.state = dst
            record.states_seen.append(dst)
            if dst == "estop" or dst.startswith("estop."):
                record.estops += 1
            console.transition(loop.time(), robot, str(entry.get("src")), dst,
                               str(entry.get("trigger")))
            if player is not None:
                player.state_changed()
        events.append(entry)

    rigs: list[SimRig] = []
    actors: list[SimActors] = []
    viz: VizSession | None = None

    async def close_hardware() -> None:
        for rig in rigs:
            await rig.close()
        for a in actors:
            await a.close()
        if viz is not None:  # the recording is finished, the live view's server stopped
            viz.close()

    def watched(name: str, daemon: Daemon) -> Daemon:
        daemon.add_event_listener(functools.partial(on_event, name))
        if viz is not None:
            viz.watch_daemon(name, daemon)
        return daemon

    def set_payload(robot: str, kg: float) -> None:
        if robot in robots:
            robots[robot].body.payload_kg = kg

    def robot_room(robot: str) -> str | None:
        if robot not in robots:
            return None
        pose = robots[robot].body.pose
        return scenario.world.room_at(pose.x_m, pose.y_m)

    def payload_kg(robot: str) -> float:
        return robots[robot].body.payload_kg if robot in robots else 0.0

    try:
        viz = open_sim_viz(args, scenario.name, len(scenario.robots), console.line)
        settings_of = [robot_settings(scenario, spec, getattr(args, "config", None))
                       for spec in scenario.robots]
        context = ActorContext(scenario, workdir, origin, lambda ev: on_event("", ev),
                               set_payload, robot_room, payload_kg,
                               lambda n: robots[n].record.state if n in robots else None,
                               getattr(args, "fleet_url", None),
                               getattr(args, "fleet_token_file", None))
        actors_of: dict[str, SimActors | None] = {}
        for settings in settings_of:
            name = settings.get("robot.profile")
            if name not in actors_of:
                factory = actors_factory(name)
                actors_of[name] = factory(context) if factory is not None else None
        actors = [a for a in actors_of.values() if a is not None]
        site: list[SimActors] = []
        if "fleet" in scenario.raw:  # the fleet server's imports take seconds: only then
            from sim.actors.site_fleet import site_fleet_for

            fleet = site_fleet_for(context, [
                (s.get("robot.name"), slice_of(s.get("robot.profile")).runs_fleet)
                for s in settings_of])
            site = [fleet] if fleet is not None else []
        actors += site
        for a in actors:
            await a.start()
        for index, (spec, settings) in enumerate(zip(scenario.robots, settings_of, strict=True)):
            mine = actors_of[settings.get("robot.profile")]
            if mine is not None:
                mine.configure_robot(settings)
            for a in site:  # it serves only the robots it was made for
                a.configure_robot(settings)
            body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                                 spec.body, rng=random.Random(f"{seed}:{spec.name}:body"),
                                 payload_kg=spec.payload_kg, clock=loop.time)
            profile = PROFILES.build(settings.get("robot.profile"))
            rig = await open_sim_rig(scenario.world, body, settings, seed=seed, index=index,
                                     mcu=getattr(args, "mcu", "fake") or "fake",
                                     needs=tuple(profile.devices),
                                     own=slice_of(settings.get("robot.profile")))
            rigs.append(rig)
            if mine is not None:
                mine.attach(rig)
            for a in site:
                a.attach(rig)
            socket_path = _socket_path(getattr(args, "socket", None), workdir, spec.name, index)
            socket_why = socket_problem(socket_path)
            if socket_why is not None:  # no robot runs without its socket: exit 2, say why
                msg = f"--socket {socket_path}: {socket_why}"
                raise ValueError(msg)
            daemon = watched(spec.name, Daemon(
                settings, rig.devices, profile, state_dir=workdir / spec.name,
                socket_path=socket_path, wall_clock=wall_clock, notify=False,
                handle_signals=False, telemetry=telemetry_of(viz, spec.name)))
            robots[spec.name] = SimRobot(spec, settings, body, rig, daemon,
                                    RobotRecord(spec.name, body), socket_path)
    except (ConfigError, ValueError, ScenarioError, VizError) as exc:  # SiteError too
        print(f"robotd sim: {exc}")
        await close_hardware()
        return 2
    def rebuild(name: str) -> Daemon:
        """A new daemon for ``robot.restart``: same settings, devices, state dir, socket."""
        r = robots[name]
        return watched(name, Daemon(r.settings, r.rig.devices,
                                    PROFILES.build(r.settings.get("robot.profile")),
                                    state_dir=workdir / name, socket_path=r.socket_path,
                                    wall_clock=wall_clock, notify=False, handle_signals=False,
                                    telemetry=telemetry_of(viz, name)))

    daemon_tasks: dict[str, asyncio.Task[Any]] = {}
    if scenario.world.robots_see_each_other:
        for r in robots.values():
            r.body.others = [o.body for o in robots.values() if o is not r]

    for r in robots.values():
        console.line(f"{r.spec.name}: profile {r.settings.get('robot.profile')}, "
                     f"control socket {r.socket_path}")
    recorder = PathRecorder({n: r.body for n, r in robots.items()}, sample_s=_WATCH_PERIOD_S,
                            state_of=lambda n: robots[n].record.state)
    def on_script_event(event: dict[str, Any]) -> None:
        robot = str(event.pop("robot", "") or next(iter(robots)))
        on_event(robot, event)

    keeper = DaemonKeeper(robots, daemon_tasks, rebuild, on_script_event)

    try:
        player = ScriptPlayer(scenario, {n: r.rig for n, r in robots.items()}, on_script_event,
                              console, state_of=lambda n: robots[n].record.state,
                              daemons=keeper)
    except ScenarioError as exc:
        print(f"robotd sim: {scenario.source}: {exc}")
        await close_hardware()
        return 2
    interrupted = asyncio.Event()
    with contextlib.suppress(NotImplementedError, RuntimeError):
        loop.add_signal_handler(signal.SIGINT, interrupted.set)
        loop.add_signal_handler(signal.SIGTERM, interrupted.set)

    tasks = [asyncio.create_task(r.rig.run(), name=f"rig.{n}", context=keeper.context_of(n))
             for n, r in robots.items()]
    daemon_tasks.update({n: asyncio.create_task(r.daemon.run(), name=f"daemon.{n}",
                                                context=keeper.context_of(n))
                         for n, r in robots.items()})
    tasks.append(asyncio.create_task(player.run(), name="script"))
    people = [asyncio.create_task(coro, name=name) for a in actors for name, coro in a.people()]
    staff = [asyncio.create_task(coro, name=name)
             for a in actors for name, coro in a.background()]
    tasks += staff
    # The live view rides on the watch's ticks: a timer of its own would change the run.
    feed = SimFeed(viz, scenario.world, recorder.tracks) if viz is not None else None

    start = loop.time()
    limit = scenario.success.time_limit_s
    extra: list[str] = []
    seen_collisions = {n: 0 for n in robots}
    records = {n: r.record for n, r in robots.items()}
    observers = {n: functools.partial(on_event, n) for n in robots}
    touching: set[tuple[str, str]] = set()

    def watch() -> bool:
        """One watch tick; True when the run is over."""
        now = loop.time() - start
        if scenario.world.robots_see_each_other and len(robots) > 1:
            _touch(robots, touching, loop.time())
        for n, r in robots.items():
            _observe(scenario, r, seen_collisions, observers[n], console)
        console.progress(now, {n: r.record.state for n, r in robots.items()})
        dead = [n for n, t in daemon_tasks.items() if t.done()]
        if dead:
            extra.append(f"daemon of {', '.join(dead)} stopped early: "
                         f"{_task_outcome(daemon_tasks[dead[0]])}")
            return True
        if player is not None and player.done and finished(scenario, records) \
                and all(t.done() for t in people):
            return True
        if now >= limit:
            return True
        if interrupted.is_set():
            extra.append("interrupted")
            return True
        return False

    def tick() -> float | None:
        recorder.sample(loop.time())  # the paths are sampled at the watch's rate
        if feed is not None:
            feed.tick()
        return None if watch() else _WATCH_PERIOD_S

    recorder.sample(start)
    await timer_chain(tick, _WATCH_PERIOD_S)
    elapsed = loop.time() - start
    if feed is not None:
        feed.flush()  # the true poses a recording holds back

    await keeper.close()
    for n, r in robots.items():
        if keeper.is_down(n):
            daemon_tasks[n].cancel()  # killed and never restarted: nothing to stop
        r.daemon.request_stop()
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(asyncio.gather(*daemon_tasks.values(), return_exceptions=True),
                               _STOP_TIMEOUT_S)
    for task in [*tasks, *people]:
        task.cancel()
    outcomes = await asyncio.gather(*people, *staff, return_exceptions=True)
    await asyncio.gather(*tasks, return_exceptions=True)
    # An actor that raised stopped doing its part: say so rather than judge the run without it.
    extra += [f"actor {task.get_name()} failed: {type(outcome).__name__}: {outcome}"
              for task, outcome in zip([*people, *staff], outcomes, strict=True)
              if isinstance(outcome, Exception)]
    for a in actors:
        extra += a.failures()
    extra += player.steps_not_run()
    await close_hardware()

    # Interrupted by hand: the unmet conditions say nothing, only that it was stopped.
    reasons = ["interrupted"] if interrupted.is_set() else \
        failures(scenario, records, elapsed, extra, events,
                 paced=bool(getattr(args, "realtime", False)) or getattr(args, "speed", None)
                 is not None)
    ok = not reasons
    figures = summary_figures(records, scenario, events)
    events.append({"t": loop.time(), "kind": "result", "ok": ok, "reasons": reasons,
                   "figures": figures})
    return SimResult(ok, reasons, elapsed, figures, events, recorder.tracks, seed,
                     interrupted.is_set())


@dataclass
class SimResult:
    ok: bool
    reasons: list[str]
    sim_s: float
    figures: dict[str, Any]
    events: list[dict[str, Any]]
    tracks: dict[str, list[TrackPoint]]
    seed: int
    interrupted: bool = False


def _report(args: argparse.Namespace, scenario: Scenario, result: SimResult,
            console: SimConsole, run_wall_s: float) -> int:
    report_dir = getattr(args, "report", None)
    if report_dir:
        out = Path(report_dir)
        write_events(out / "events.jsonl", result.events)
        draw_trajectory(out / "trajectory.png", scenario.world, result.tracks, result.events,
                        f"{scenario.name} (seed {result.seed}): "
                        f"{'success' if result.ok else 'FAILED'}", scenario.profiles)
    console.summary(scenario=scenario.name, ok=result.ok, reasons=result.reasons,
                    sim_s=result.sim_s, figures=result.figures,
                    report_dir=str(Path(report_dir)) if report_dir else None,
                    run_wall_s=run_wall_s)
    if result.interrupted:
        return 130
    return 0 if result.ok else 1


def _touch(robots: dict[str, SimRobot], touching: set[tuple[str, str]], t_s: float) -> None:
    """Robots that see each other can run into each other: two footprints that overlap are a
    collision of both (once per contact; watched at the watch's 10 Hz, a robot drives ~2 cm
    between two looks)."""
    names = sorted(robots)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            pa, pb = robots[a].body.pose, robots[b].body.pose
            reach = robots[a].body.params.radius_m + robots[b].body.params.radius_m
            pair = (a, b)
            if pa.distance_to(pb.x_m, pb.y_m) >= reach:
                touching.discard(pair)
            elif pair not in touching:
                touching.add(pair)
                x, y = (pa.x_m + pb.x_m) / 2, (pa.y_m + pb.y_m) / 2
                for name in pair:
                    robots[name].body.collisions.append(Collision(t_s, x, y))


def _observe(scenario: Scenario, r: SimRobot, seen_collisions: dict[str, int],
             record: Any, console: SimConsole) -> None:
    """One watch tick for one robot: cross-track error, new collisions, deadman stops."""
    name = r.spec.name
    body = r.body
    moving = abs(body.wheel_mps[0] + body.wheel_mps[1]) / 2 > 0.05
    if scenario.world.lines and moving and r.record.state.startswith("mission"):
        pose = body.pose
        r.record.cross_track_sum_m += scenario.world.cross_track_m(pose.x_m, pose.y_m)
        r.record.cross_track_samples += 1
    for c in body.collisions[seen_collisions[name]:]:
        record({"t": c.t_s, "kind": "collision", "x_m": c.x_m, "y_m": c.y_m})
        console.event(c.t_s, f"{name}: collision at ({c.x_m:.2f}, {c.y_m:.2f})")
    seen_collisions[name] = len(body.collisions)
    for t_stop, last_cmd in r.rig.new_deadman_stops():
        pose = body.pose
        record({"t": t_stop, "kind": "deadman", "last_command_t": last_cmd,
                "x_m": pose.x_m, "y_m": pose.y_m})
        console.event(t_stop, f"{name}: motor board deadman stopped the motors")


def _socket_path(given: str | None, workdir: Path, name: str, index: int) -> str:
    if given:
        return given if index == 0 else f"{given}.{name}"
    return str(workdir / name / "control.sock")


def _task_outcome(task: asyncio.Task[Any]) -> str:
    if task.cancelled():
        return "cancelled"
    exc = task.exception()
    return f"{type(exc).__name__}: {exc}" if exc else f"exit code {task.result()}"
