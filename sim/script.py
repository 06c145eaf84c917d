"""Plays a scenario's script: timed events done to the world and the robots' hardware."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import structlog

from sim.actions import Step, script_actions
from sim.scenario import Scenario, ScenarioError, ScriptStep

if TYPE_CHECKING:
    from sim.console import SimConsole
    from sim.crash import DaemonKeeper
    from sim.rig import SimRig

log = structlog.get_logger(__name__)

class ScriptPlayer:
    """Runs each step at its time (seconds from the start), on the loop's clock."""

    def __init__(self, scenario: Scenario, rigs: dict[str, SimRig],
                 record: Callable[[dict[str, Any]], None], console: SimConsole,
                 state_of: Callable[[str], str] = lambda _robot: "",
                 daemons: DaemonKeeper | None = None) -> None:
        self.scenario = scenario
        self.daemons = daemons
        self.state_of = state_of
        self.rigs = rigs
        self.record = record
        self.console = console
        self.done = not scenario.script
        self._state_changed = asyncio.Event()
        self._pending: set[asyncio.Task[None]] = set()
        self.steps_done = 0
        """How many steps of the script have run (in their time order)."""
        self.actions = script_actions()
        for i, step in enumerate(scenario.script):
            if step.action not in self.actions:
                msg = (f"script[{i}].action: unknown action {step.action!r} "
                       f"(known: {', '.join(self.actions)})")
                raise ScenarioError(msg)
            robot = step.args.get("robot")
            if robot is not None and robot not in rigs:
                msg = f"script[{i}].robot: no robot named {robot!r}"
                raise ScenarioError(msg)

    def steps_not_run(self) -> list[str]:
        """Each step the run ended before (a ``when_state`` that never came, a time past the
        run's end), as a reason: a scenario whose script did not happen has not shown it."""
        reasons = []
        for step in self.scenario.script[self.steps_done:]:
            when = step.args.get("when_state")
            why = (f"its when_state {when!r} never came" if when is not None
                   else f"the run ended before {step.at_s:g} s")
            reasons.append(f"script step {step.action} (at_s {step.at_s:g}) never ran: {why}")
        return reasons

    def state_changed(self) -> None:
        """A robot changed state (steps with ``when_state`` wait for this)."""
        self._state_changed.set()

    async def run(self) -> None:
        loop = asyncio.get_running_loop()
        start = loop.time()
        for step in self.scenario.script:
            delay = start + step.at_s - loop.time()
            if delay > 0:
                await asyncio.sleep(delay)
            when = step.args.get("when_state")
            if when is not None:
                robot = str(step.args.get("robot", next(iter(self.rigs))))
                while not _in_state(self.state_of(robot), str(when)):
                    self._state_changed.clear()
                    await self._state_changed.wait()
                await asyncio.sleep(float(step.args.get("delay_s", 0.0)))
            await self._do(step)
            self.steps_done += 1
        if self._pending:
            await asyncio.gather(*self._pending)
        self.done = True

    async def _do(self, step: ScriptStep) -> None:
        robot = str(step.args.get("robot", next(iter(self.rigs))))
        rig = self.rigs[robot]
        args = step.args
        pose = rig.body.pose
        self.record({"kind": "script", "action": step.action, "robot": robot,
                     "x_m": pose.x_m, "y_m": pose.y_m,
                     **{k: v for k, v in args.items() if k not in ("robot", "when_state",
                                                                     "delay_s")}})
        self.console.event(asyncio.get_running_loop().time(),
                           f"script: {step.action} {_args_text(args)}".rstrip())
        done = self.actions[step.action](Step(
            self.scenario, robot, rig, args,
            lambda delay_s, fn, name: self._later(delay_s, fn, name, robot), self.daemons))
        if done is not None:
            await done

    def _later(self, delay_s: float, fn: Callable[[], None], name: str, robot: str) -> None:
        async def later() -> None:
            await asyncio.sleep(delay_s)
            fn()
            pose = self.rigs[robot].body.pose
            self.record({"kind": "script", "action": name, "robot": robot,
                         "x_m": pose.x_m, "y_m": pose.y_m})
            self.console.event(asyncio.get_running_loop().time(), f"script: {name}")

        task = asyncio.create_task(later())
        self._pending.add(task)
        task.add_done_callback(self._pending.discard)


def _args_text(args: dict[str, Any]) -> str:
    return " ".join(f"{k}={v}" for k, v in args.items()
                    if k not in ("when_state", "delay_s", "robot"))


def _in_state(state: str, wanted: str) -> bool:
    return state == wanted or state.startswith(wanted + ".")
