"""The robot's hierarchical state machine: tables from ``machine_tables`` plus the profile's.

All triggers go through one queue and one driver task, so transitions never overlap (the
``transitions`` async machine cancels a running transition when another starts) and state
timeouts cannot fire into a state that was already left.
"""

from __future__ import annotations

import asyncio
import functools
from collections.abc import Awaitable, Callable, Coroutine
from dataclasses import dataclass, field
from typing import Any

import structlog
from transitions.extensions.asyncio import (
    AsyncTimeout,
    HierarchicalAsyncMachine,
    NestedAsyncState,
)

from behaviours.context import RobotContext
from behaviours.machine_part import MachinePart
from behaviours.machine_tables import (
    CORE_TRANSITIONS,
    CoreTrigger,
    RootState,
    callback_names,
    root_states,
)
from behaviours.profile import Profile, StateTask

log = structlog.get_logger(__name__)

TransitionSink = Callable[[str, str, str], None]
MAX_TASK_RESTARTS = 1
"""A state task that ended with its trigger refused is started again at most this often per
entry of its state (a task that keeps firing a refused trigger would loop for ever)."""


def _outward(path: str) -> list[str]:
    """A dotted state path and its parents, innermost first."""
    parts = path.split(".")
    return [".".join(parts[:i]) for i in range(len(parts), 0, -1)]


class DottedState(AsyncTimeout, NestedAsyncState):
    """Nested, async, with state timeouts; paths are written ``docking.approach``."""

    separator = "."


class _Machine(HierarchicalAsyncMachine):
    state_cls = DottedState


class MachineModel:
    """The machine's model: the guards and actions the core tables name (kept short)."""

    def __init__(self, runtime: RobotMachine, profile: Profile,
                 parts: tuple[MachinePart, ...] = ()) -> None:
        self._runtime = runtime
        self._profile = profile
        self._part_callbacks = tuple(p.callbacks for p in parts if p.callbacks is not None)
        self.state = RootState.BOOT

    def __getattr__(self, name: str) -> Any:
        # Names in a part's tables are its callbacks' methods; in a profile's, the profile's.
        if name.startswith("_"):
            raise AttributeError(name)
        for callbacks in self._part_callbacks:
            if hasattr(callbacks, name):
                return getattr(callbacks, name)
        return getattr(self._profile, name)

    async def stop_motors(self, _event: Any) -> None:
        await self._runtime.stop_motors()

    def timed_out(self, _event: Any) -> None:
        self._runtime.post_timeout()


@dataclass
class _Request:
    trigger: str
    kwargs: dict[str, Any]
    result: asyncio.Future[bool] | None = None
    generation: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)


class RobotMachine:
    """Owns the machine and runs it as a service (``run``) that processes triggers in order.

    Args:
        profile: nests its mission states and transitions, names its state tasks and hooks.
        ctx: the behaviours' context; attached to this machine.
        on_transition: told (src, dst, trigger) after every transition.
        stop_motors: stops the wheels (bounded in time); awaited on entering estop and idle.
    """

    name = "machine"
    critical = True
    depends_on: tuple[str, ...] = ()

    def __init__(self, profile: Profile, ctx: RobotContext, *, on_transition: TransitionSink,
                 stop_motors: Callable[[], Awaitable[None]]) -> None:
        self.profile = profile
        self.ctx = ctx
        self._on_transition = on_transition
        self._stop_motors = stop_motors
        self._queue: asyncio.Queue[_Request] = asyncio.Queue()
        self._generation = 0
        self._before: str = RootState.BOOT
        self._driver: asyncio.Task[None] | None = None
        self._tasks: dict[str, asyncio.Task[None]] = {}
        self._restarts: dict[str, int] = {}
        self._watched: set[str] = set()
        self._state_tasks: dict[str, StateTask] = dict(profile.state_tasks())
        parts = tuple(profile.machine_parts(ctx))
        self.states = root_states(profile.mission_states(), parts)
        # A part's rows before the core's: where both have a trigger from one state, the
        # part's more specific row is tried first.
        self.transitions = [*(t for p in parts for t in p.transitions), *CORE_TRANSITIONS,
                            *profile.mission_transitions()]
        self.model = MachineModel(self, profile, parts)
        self.machine = _Machine(
            model=self.model, states=self.states, transitions=self.transitions,
            initial=RootState.BOOT, send_event=True, auto_transitions=False,
            ignore_invalid_triggers=True, after_state_change=[self._changed],
        )
        self._triggers = set(self.machine.events)
        self._allowed: dict[str, list[str]] = {}
        for path in self.machine.get_nested_state_names():
            state = self.machine.get_state(path)
            state.add_callback("enter", self._enter_hook(path))
            state.add_callback("exit", self._exit_hook(path))
        unknown = set(self._state_tasks) - set(self.machine.get_nested_state_names())
        if unknown:
            msg = f"profile {profile.name}: state_tasks name unknown states: {sorted(unknown)}"
            raise ValueError(msg)
        ctx.attach(self)

    @property
    def state(self) -> str:
        return str(self.model.state)

    @property
    def triggers(self) -> list[str]:
        return sorted(self._triggers)

    def allowed_triggers(self) -> list[str]:
        """Triggers that the current state (or a state around it) has a transition for."""
        state = self.state
        if state not in self._allowed:
            self._allowed[state] = sorted(
                t for t in self.machine.get_triggers(state) if t in self._triggers)
        return list(self._allowed[state])

    def missing_callbacks(self) -> list[str]:
        """Callback names in the tables that neither the model nor the profile defines."""
        names = callback_names(self.states, self.transitions)
        return sorted(n for n in names if not hasattr(self.model, n))

    async def stop_motors(self) -> None:
        await self._stop_motors()

    async def trigger(self, name: str, **kwargs: Any) -> bool:
        """Fire ``name`` after the triggers before it; False if the state does not allow it."""
        if name not in self._triggers:
            log.warning("state.unknown_trigger", trigger=name, state=self.state)
            return False
        if self._driver is None or self._driver.done() or asyncio.current_task() is self._driver:
            # From inside a transition (or with no driver running) it cannot be awaited: queue it.
            self._queue.put_nowait(_Request(name, kwargs))
            return name in self.allowed_triggers()
        future: asyncio.Future[bool] = asyncio.get_running_loop().create_future()
        self._queue.put_nowait(_Request(name, kwargs, future))
        return await future

    def post(self, name: str, **kwargs: Any) -> None:
        """Queue a trigger without waiting for it."""
        self._queue.put_nowait(_Request(name, kwargs))

    def post_timeout(self) -> None:
        self._queue.put_nowait(_Request(CoreTrigger.TIMEOUT, {}, generation=self._generation))

    def halt_behaviours(self) -> None:
        """Cancel every state task (before the motors are stopped at shutdown)."""
        for task in self._tasks.values():
            task.cancel()
        self._tasks.clear()

    async def run(self, ready: Callable[[], None]) -> None:
        self._driver = asyncio.current_task()
        ready()
        try:
            while True:
                request = await self._queue.get()
                result = await self._fire(request)
                if request.result is not None and not request.result.done():
                    request.result.set_result(result)
                if self._driver is not None and self._driver.cancelling():
                    # transitions swallows a CancelledError that lands inside a transition.
                    raise asyncio.CancelledError
        finally:
            self.halt_behaviours()

    async def _fire(self, request: _Request) -> bool:
        if request.generation is not None and request.generation != self._generation:
            return False  # a timeout of a state that was left meanwhile
        self._before = self.state
        try:
            result = bool(await self.model.trigger(request.trigger, **request.kwargs))
        except Exception:
            log.exception("state.trigger_failed", trigger=request.trigger, state=self.state)
            return False
        if not result:
            # The error table's invalid transition: logged as an error, the state kept, and
            # a recovery attempted: a state task that fired it and ended would leave the
            # robot in a state nothing drives any more, so it is started again (once per
            # entry of that state).
            log.error("state.refused", trigger=request.trigger, state=self.state,
                      allowed=self.allowed_triggers())
            self._recover_refused(request.trigger)
        return result

    def _recover_refused(self, trigger: str) -> None:
        """The current state's task (innermost first), once it has ended with the machine
        still in that state, is started again; at most ``MAX_TASK_RESTARTS`` times per entry
        of that state. (The task that fired the refused trigger is usually still awaiting
        the answer: it is watched until it ends.)"""
        generation = self._generation
        for path in _outward(self.state):
            task = self._tasks.get(path)
            if task is None or path not in self._state_tasks:
                continue
            if task.done():
                self._restart(path, trigger, generation)
            elif path not in self._watched:
                self._watched.add(path)
                task.add_done_callback(functools.partial(
                    self._ended_after_refusal, path=path, trigger=trigger,
                    generation=generation))
            return

    def _ended_after_refusal(self, task: asyncio.Task[None], *, path: str, trigger: str,
                             generation: int) -> None:
        self._watched.discard(path)
        if not task.cancelled() and self._tasks.get(path) is task:
            self._restart(path, trigger, generation)

    def _restart(self, path: str, trigger: str, generation: int) -> None:
        if generation != self._generation:
            return  # the machine moved on meanwhile: nothing to recover
        restarts = self._restarts.get(path, 0)
        if restarts >= MAX_TASK_RESTARTS:
            log.error("state.task_not_restarted", state=path, trigger=trigger,
                      restarts=restarts)
            return
        self._restarts[path] = restarts + 1
        log.warning("state.task_restarted", state=path, trigger=trigger, restarts=restarts + 1)
        self._tasks[path] = asyncio.create_task(
            self._run_state_task(path, self._state_tasks[path]), name=f"state:{path}")

    def _changed(self, event: Any) -> None:
        self._generation += 1
        self._on_transition(self._before, self.state, event.event.name)

    def restore(self) -> None:
        """Restore what the profile declared must survive a restart (called in ``boot``)."""
        for record in self.profile.mission_records():
            self.ctx.persisted(record)

    async def _latch_estop(self, event: Any) -> None:
        # Latched, durably, before the trigger's caller hears that the robot is in estop.
        kwargs = getattr(event, "kwargs", {}) or {}
        name = event.event.name if getattr(event, "event", None) is not None else CoreTrigger.ESTOP
        source = str(kwargs.get("source") or name)
        reason = str(kwargs.get("reason") or f"{self._before} {name}")
        await self.ctx.estop_latch.set(source, reason)

    async def _unlatch_estop(self, event: Any) -> None:
        transition = getattr(event, "transition", None)
        if transition is not None and transition.dest == RootState.ESTOP:
            return  # estop again: still latched
        await self.ctx.estop_latch.clear(by=event.event.name)

    def _enter_hook(self, path: str) -> Callable[[Any], Coroutine[Any, Any, None]]:
        async def entered(event: Any) -> None:
            if path == RootState.ESTOP:
                await self._latch_estop(event)
            self.profile.on_enter(path, self.ctx)
            self._restarts.pop(path, None)
            task_fn = self._state_tasks.get(path)
            if task_fn is not None:
                self._tasks[path] = asyncio.create_task(self._run_state_task(path, task_fn),
                                                        name=f"state:{path}")
        return entered

    def _exit_hook(self, path: str) -> Callable[[Any], Coroutine[Any, Any, None]]:
        async def exited(event: Any) -> None:
            task = self._tasks.pop(path, None)
            if task is not None:
                task.cancel()
            if path == RootState.ESTOP:
                await self._unlatch_estop(event)
            self.profile.on_exit(path, self.ctx)
        return exited

    async def _run_state_task(self, path: str, task_fn: StateTask) -> None:
        try:
            await task_fn(self.ctx)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a failing behaviour sends the robot to recovery
            log.exception("behaviour.failed", state=path)
            self.ctx.emit("behaviour", state=path, status="failed", error=repr(exc))
            self.post(CoreTrigger.FAULT, reason=f"{path}: {exc!r}")
