"""The daemon: builds the machine and services around a profile, runs them, stops them safely."""

from __future__ import annotations

import asyncio
import contextlib
import gc
import os
import signal
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import structlog

from behaviours.context import RobotContext
from behaviours.machine import RobotMachine
from behaviours.profile import Profile
from behaviours.service import Service
from hal.backend import Devices
from hal.ports import WallClock
from hal.telemetry import NULL_TELEMETRY, Telemetry
from robotd import __version__
from robotd.config import ConfigError, Settings, load_config
from robotd.config.overrides import overrides_path
from robotd.control.admission import ClientPolicy
from robotd.control.methods import control_handlers
from robotd.control.server import ControlServer
from robotd.health import LoopMonitor, WatchdogFeeder
from robotd.logs import set_level
from robotd.sdnotify import Notifier
from robotd.site_link import site_report_services
from robotd.step_cpu import StepCpu
from robotd.store import StateStore
from robotd.supervisor import DeviceService, RestartPolicy, StartFailed, Supervisor

log = structlog.get_logger(__name__)

EventListener = Callable[[dict[str, Any]], None]
EVENT_HISTORY = 1000
MOTOR_STOP_TIMEOUT_S = 1.0
STATE_FILE = "state.sqlite3"
TOPIC_OF_KIND = {"transition": "state"}


class Daemon:
    """One robot's runtime: store, state machine, devices, behaviours, control socket.

    Args:
        settings: the checked configuration (tuned live through the control socket).
        devices: built by ``robotd.hardware`` or the simulator.
        profile: the robot's mission states, transitions and behaviour services.
        state_dir: where the state store and the tuning overrides live.
        socket_path: control socket path, or None for no socket.
        wall_clock: the one source of wall-clock timestamps.
        config_path: the file ``reload``/SIGHUP reads again (None: nothing to reload).
        notify: tell systemd READY/WATCHDOG/STOPPING through ``$NOTIFY_SOCKET``.
        handle_signals: SIGTERM/SIGINT stop, SIGHUP reloads (off inside tests and the sim).
        freeze_gc: once started, collect and freeze what start-up made (``robotd run``; not in
            processes that run many daemons, where frozen garbage would never be freed).
        telemetry: what the behaviours publish to the live view (``robotd.viz``), or nothing.
    """

    def __init__(self, settings: Settings, devices: Devices, profile: Profile, *,
                 state_dir: Path, socket_path: str | None, wall_clock: WallClock,
                 config_path: Path | None = None, notify: bool = True,
                 handle_signals: bool = True, freeze_gc: bool = False,
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.settings = settings
        self.devices = devices
        self.profile = profile
        self.state_dir = Path(state_dir)
        self.socket_path = socket_path
        self.wall_clock = wall_clock
        self.config_path = config_path
        self.handle_signals = handle_signals
        self.freeze_gc = freeze_gc
        self.notifier = Notifier() if notify else Notifier({})
        self.ready = asyncio.Event()
        self.events: deque[dict[str, Any]] = deque(maxlen=EVENT_HISTORY)
        self._listeners: list[EventListener] = []
        self._stop = asyncio.Event()
        self._started_s: float | None = None
        self._crashed = False
        self.start_problems: list[str] = []
        self.store = StateStore(self.state_dir / STATE_FILE)
        self.context = RobotContext(devices, settings, self.store, wall_clock, self.emit,
                                    telemetry=telemetry, state_dir=self.state_dir)
        self.machine = RobotMachine(profile, self.context, on_transition=self._on_transition,
                                    stop_motors=self.stop_motors)
        self.monitor = LoopMonitor(lambda: float(settings.get("supervisor.lag_warn_ms")))
        self.step_cpu: StepCpu | None = None  # `robotd run` sets it: ROBOTD_STEP_CPU_MS
        self.control: ControlServer | None = None
        if socket_path is not None:
            self.control = ControlServer(
                socket_path, control_handlers(self),
                max_clients=settings.get("control.max_clients"),
                queue_limit=settings.get("control.client_queue"),
                policy=ClientPolicy.from_settings(settings.get))
        self.supervisor = Supervisor(
            self._services(), policy=RestartPolicy(
                base_s=settings.get("supervisor.restart_base_s"),
                max_s=settings.get("supervisor.restart_max_s"),
                max_failures=settings.get("supervisor.max_failures")),
            emit=self.emit, on_critical=self._critical_failure)
        settings.watch("logging.level", lambda _key, value: set_level(str(value)))
        if devices.motors is not None:
            devices.motors.on_link_change(self._link_changed)

    def _services(self) -> list[Service]:
        services: list[Service] = [self.store, self.machine, self.monitor,
                                   WatchdogFeeder(self.notifier, self.monitor)]
        if self.control is not None:
            services.append(self.control)
        services += [DeviceService(d) for d in self.devices.distinct()]
        return services

    @property
    def state(self) -> str:
        return self.machine.state

    @property
    def uptime_s(self) -> float:
        if self._started_s is None:
            return 0.0
        return asyncio.get_running_loop().time() - self._started_s

    def add_event_listener(self, listener: EventListener) -> None:
        """``listener(event)`` gets every event: ``{"t", "kind", ...fields}``."""
        self._listeners.append(listener)

    def emit(self, kind: str, /, **fields: Any) -> None:
        try:
            now_s = asyncio.get_running_loop().time()
        except RuntimeError:
            now_s = 0.0
        event = {"t": round(now_s, 6), "kind": kind, **fields}
        self.events.append(event)
        for listener in list(self._listeners):
            try:
                listener(event)
            except Exception:  # a listener's bug must not stop the robot
                log.exception("daemon.listener_failed", kind=kind)
        if self.control is not None:
            self.control.publish(TOPIC_OF_KIND.get(kind, kind), event)
            self.control.publish("events", event)

    def request_stop(self) -> None:
        """Ask ``run`` to stop everything and return (what SIGTERM does)."""
        log.info("daemon.stop_requested")
        self._stop.set()

    async def run(self) -> int:
        """Start everything, say READY=1, wait for a stop request, stop everything; exit code."""
        loop = asyncio.get_running_loop()
        self._started_s = loop.time()
        self._install_signals(loop)
        log.info("daemon.starting", robot=self.settings.get("robot.name"),
                 profile=self.profile.name, pid=os.getpid(), version=__version__)
        try:
            try:
                await self.supervisor.start()
                self.machine.restore()
                await self._leave_boot()
                self.supervisor.add(self.profile.services(self.context))
                self.supervisor.add(site_report_services(self.profile, self.context,
                                                         self.estop))
                await self.supervisor.start()
            except (StartFailed, ValueError) as exc:
                self.start_problems = getattr(exc, "problems", [str(exc)])
                for problem in self.start_problems:
                    log.error("daemon.start_failed", problem=problem)
                return 1
            if self.freeze_gc:
                _freeze_startup_objects()
            self.ready.set()
            self.notifier.notify("READY=1", f"STATUS=state {self.state}")
            log.info("daemon.ready", startup_s=round(loop.time() - self._started_s, 3),
                     state=self.state)
            await self._stop.wait()
            return 0
        finally:
            if self._crashed:
                await self._vanish()
            else:
                await self._shutdown()
            self._remove_signals(loop)

    def crash(self) -> None:
        """Die as under SIGKILL, for the simulator's ``robot.kill``: from now on nothing
        reaches the state store (what is not written yet is lost) and, once the caller cancels
        ``run``, no orderly stop runs: the motors are not stopped (the board's deadman does
        it) and nothing is flushed. Only what an in-process daemon must release is released:
        its tasks, its socket and its devices' ports."""
        self._crashed = True
        self.store.abandon()
        self.machine.halt_behaviours()
        log.error("daemon.crashed", state=self.state)

    async def _vanish(self) -> None:
        self.machine.halt_behaviours()
        await self.supervisor.stop(self.settings.get("supervisor.stop_timeout_s"))
        self.notifier.close()

    async def _shutdown(self) -> None:
        self.notifier.notify("STOPPING=1")
        self.machine.halt_behaviours()
        try:
            await self.stop_motors()
        finally:
            problems = await self.supervisor.stop(self.settings.get("supervisor.stop_timeout_s"))
            await self.store.aclose()
            self.notifier.close()
            log.info("daemon.stopped", problems=problems, state=self.state)

    async def stop_motors(self) -> None:
        """Stop the wheels, bounded in time; never raises."""
        motors = self.devices.motors
        if motors is None:
            return
        try:
            await asyncio.wait_for(motors.stop(), MOTOR_STOP_TIMEOUT_S)
            log.info("motors.stopped")
        except Exception as exc:  # the link may be down: the MCU's deadman stops them then
            log.warning("motors.stop_failed", error=repr(exc))

    async def _leave_boot(self) -> None:
        """To ``idle``, or back to ``estop`` when the latch survived a crash or a stop: the
        profile's services then start (once the devices are up) with the motors stopped."""
        latch = self.context.estop_latch.record
        if latch is None:
            await self.machine.trigger("booted")
            return
        log.error("estop.latched_at_start", **latch)
        self.emit("estop", restored=True, state=self.state, **latch)
        await self.machine.trigger("estop", source=str(latch.get("source")),
                                   reason=str(latch.get("reason")))

    async def estop(self, reason: str, source: str = "robotctl") -> bool:
        """Stop the motors at once, then enter ``estop`` (latched durably before it returns)."""
        log.error("estop", reason=reason, source=source, state=self.state)
        self.emit("estop", reason=reason, source=source, state=self.state)
        await self.stop_motors()
        return await self.machine.trigger("estop", reason=reason, source=source)

    def reload(self) -> tuple[bool, list[str]]:
        """Read the config file (and overrides) again; keep the running config if it is bad."""
        if self.config_path is None:
            return False, ["no config file to reload (started without one)"]
        try:
            values = load_config(self.config_path, overrides=overrides_path(self.state_dir))
        except ConfigError as exc:
            problems = [str(p) for p in exc.problems]
            log.error("config.reload_rejected", path=str(self.config_path), problems=problems)
            self.emit("config", status="rejected", problems=problems)
            return False, problems
        changed = self.settings.replace(values, source=str(self.config_path))
        restart = [k for k in changed if not self.settings.option(k).tunable]
        log.info("config.reloaded", path=str(self.config_path), changed=changed,
                 needs_restart=restart)
        self.emit("config", status="reloaded", changed=changed, needs_restart=restart)
        return True, changed

    def _on_transition(self, src: str, dst: str, trigger: str) -> None:
        now_s = round(asyncio.get_running_loop().time(), 6)
        log.info("state.transition", src=src, dst=dst, trigger=trigger, t=now_s)
        self.emit("transition", src=src, dst=dst, trigger=trigger)
        self.notifier.notify(f"STATUS=state {dst}")

    def _critical_failure(self, service: str, error: str) -> None:
        task = asyncio.ensure_future(self.estop(f"service {service} keeps failing: {error}",
                                                source="fault"))
        task.add_done_callback(lambda t: t.exception() if not t.cancelled() else None)

    def _link_changed(self, connected: bool) -> None:
        if connected or self._stop.is_set():
            log.info("link.changed", connected=connected)
        else:
            log.warning("link.down", note="motors count as stopped until the link is back")
        self.emit("link", status="up" if connected else "down")

    def _install_signals(self, loop: asyncio.AbstractEventLoop) -> None:
        if not self.handle_signals:
            return
        loop.add_signal_handler(signal.SIGTERM, self.request_stop)
        loop.add_signal_handler(signal.SIGINT, self.request_stop)
        loop.add_signal_handler(signal.SIGHUP, self.reload)

    def _remove_signals(self, loop: asyncio.AbstractEventLoop) -> None:
        if not self.handle_signals:
            return
        for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            with contextlib.suppress(Exception):
                loop.remove_signal_handler(sig)


def _freeze_startup_objects() -> None:
    """Move everything start-up made (modules, devices, the machine: ~130k objects) out of
    the cyclic collector's reach. A full collection over them takes ~70 ms on the dev machine,
    several 13 FPS ticks and a serial heartbeat; afterwards a full collection only looks at
    what was made since. They live as long as the daemon, so nothing is lost by never
    collecting them."""
    gc.collect()
    gc.freeze()
    log.info("daemon.gc_frozen", objects=gc.get_freeze_count())

