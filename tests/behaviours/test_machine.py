"""The robot state machine: tables, dotted paths, estop, timeouts, state tasks."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from behaviours.context import RobotContext
from behaviours.docking.machine_part import docking_part
from behaviours.docking.tables import SEARCH_TIMEOUT_S as DOCK_SEARCH_TIMEOUT_S
from behaviours.docking.tables import STEP_TIMEOUT_S as DOCK_STEP_TIMEOUT_S
from behaviours.machine import MachineModel, RobotMachine
from behaviours.machine_part import MachinePart
from behaviours.machine_tables import (
    CORE_TRANSITIONS,
    ROOT_STATES,
    callback_names,
    root_states,
)
from behaviours.profile import BaseProfile, StateTask
from behaviours.profiles.idle import IdleProfile
from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults
from sim import vclock


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)


class DriveProfile(BaseProfile):
    """A profile with two mission states, a task in ``mission.drive`` and hooks recorded."""

    name = "drive"

    def __init__(self, task: StateTask | None = None) -> None:
        self.hooks: list[tuple[str, str]] = []
        self._task = task

    def mission_states(self) -> list[str | dict[str, Any]]:
        return ["drive", {"name": "unload", "on_enter": "unload_started"}]

    def mission_transitions(self) -> list[dict[str, Any]]:
        return [{"trigger": "arrived", "source": "mission.drive", "dest": "mission.unload"}]

    def state_tasks(self) -> dict[str, StateTask]:
        return {"mission.drive": self._task} if self._task else {}

    def unload_started(self, _event: Any) -> None:
        self.hooks.append(("callback", "unload_started"))

    def on_enter(self, state: str, ctx: RobotContext) -> None:
        self.hooks.append(("enter", state))

    def on_exit(self, state: str, ctx: RobotContext) -> None:
        self.hooks.append(("exit", state))


class DockingIdle(IdleProfile):
    """The idle robot with the docking capability plugged in (as the vacuum has it)."""

    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]:
        return (docking_part(ctx),)


class DockingDrive(DriveProfile):
    """``DriveProfile`` with the docking capability plugged in."""

    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]:
        return (docking_part(ctx),)


class Rig:
    def __init__(self, profile: BaseProfile) -> None:
        self.events: list[tuple[str, dict[str, Any]]] = []
        self.transitions: list[tuple[str, str, str]] = []
        self.moved = asyncio.Event()
        self.motor_stops = 0
        self.ctx = RobotContext(Devices(), Settings(defaults()), DictStore(), system_wall_clock,
                                lambda kind, **f: self.events.append((kind, f)))
        self.machine = RobotMachine(profile, self.ctx, on_transition=self._moved,
                                    stop_motors=self._stop)
        self.task: asyncio.Task[None] | None = None

    def _moved(self, src: str, dst: str, trigger: str) -> None:
        self.transitions.append((src, dst, trigger))
        self.moved.set()

    async def _stop(self) -> None:
        self.motor_stops += 1

    async def start(self) -> None:
        self.task = asyncio.create_task(self.machine.run(lambda: None))
        await asyncio.sleep(0)
        assert await self.machine.trigger("booted")

    async def close(self) -> None:
        assert self.task is not None
        self.task.cancel()
        await asyncio.gather(self.task, return_exceptions=True)


def run_with(profile: BaseProfile, body: Any) -> Any:
    async def main() -> Any:
        rig = Rig(profile)
        await rig.start()
        try:
            return await body(rig)
        finally:
            await rig.close()

    return vclock.run(main())


TO_POSITION = ["beam_detected", "field_detected", "direction_found"]
TO_DOCK = [*TO_POSITION, "front_seen", "centered", "overlap_reached", "front_both",
           "in_overlap", "approached", "center_found", "compare", "balanced", "aligned",
           "touched", "contact_made"]
FROM_ALIGN = TO_DOCK[TO_DOCK.index("center_found"):]


class TestTables:
    def test_every_callback_named_in_the_tables_exists(self) -> None:
        """Each callback/condition string in the core tables is a MachineModel method."""
        names = callback_names(root_states([]), CORE_TRANSITIONS)
        assert names, "the tables name callbacks"
        missing = sorted(n for n in names if not hasattr(MachineModel, n))
        assert missing == []

    def test_profile_callbacks_resolve_on_the_profile(self) -> None:
        """A callback a profile's table names is found on the profile."""
        async def body(rig: Rig) -> list[str]:
            return rig.machine.missing_callbacks()

        assert run_with(DriveProfile(), body) == []

    def test_root_states_are_the_designed_ones(self) -> None:
        """boot, idle, mission, docking, relocate, recovery, estop, maintenance."""
        names = [s["name"] for s in root_states([])]
        assert tuple(names) == ROOT_STATES


class TestTransitions:
    def test_states_are_dotted_lowercase_paths(self) -> None:
        """Entering docking lands in docking.search.wall_follow, shown with dots."""
        async def body(rig: Rig) -> str:
            await rig.machine.trigger("go_dock")
            await rig.machine.trigger("beam_detected")
            return rig.machine.state

        assert run_with(DockingIdle(), body) == "docking.search.force_field_detect"

    def test_every_transition_is_reported_with_source_destination_and_trigger(self) -> None:
        """on_transition hears (src, dst, trigger) for each transition, in order."""
        async def body(rig: Rig) -> list[tuple[str, str, str]]:
            await rig.machine.trigger("go_dock")
            return rig.transitions

        assert run_with(DockingIdle(), body) == [
            ("boot", "idle", "booted"), ("idle", "docking.search.wall_follow", "go_dock")]

    def test_a_refused_trigger_returns_false_and_changes_nothing(self) -> None:
        """resume outside estop is refused without an exception."""
        async def body(rig: Rig) -> tuple[bool, bool, str]:
            refused = await rig.machine.trigger("resume")
            unknown = await rig.machine.trigger("no_such_trigger")
            return refused, unknown, rig.machine.state

        assert run_with(DockingIdle(), body) == (False, False, "idle")

    @pytest.mark.parametrize("path", [
        ["start_mission"], ["go_dock"], ["go_dock", *TO_POSITION],
        ["lost"], ["maintenance"], ["start_mission", "fault"],
    ])
    def test_estop_is_reachable_from_every_state_and_stops_the_motors(
            self, path: list[str]) -> None:
        """From any state estop is entered and the motors are stopped on entry."""
        async def body(rig: Rig) -> tuple[str, int]:
            for trigger in path:
                assert await rig.machine.trigger(trigger), trigger
            stops = rig.motor_stops
            assert await rig.machine.trigger("estop")
            return rig.machine.state, rig.motor_stops - stops

        state, stops = run_with(DockingDrive(), body)
        assert state == "estop"
        assert stops >= 1

    def test_resume_leaves_estop_for_idle(self) -> None:
        async def body(rig: Rig) -> str:
            await rig.machine.trigger("estop")
            await rig.machine.trigger("resume")
            return rig.machine.state

        assert run_with(DockingIdle(), body) == "idle"

    def test_profile_states_nest_under_mission_with_hooks(self) -> None:
        """mission's first child is its initial state; enter/exit hooks see dotted paths."""
        profile = DriveProfile()

        async def body(rig: Rig) -> str:
            await rig.machine.trigger("start_mission")
            await rig.machine.trigger("arrived")
            return rig.machine.state

        assert run_with(profile, body) == "mission.unload"
        assert ("enter", "mission") in profile.hooks
        assert ("enter", "mission.drive") in profile.hooks
        assert ("exit", "mission.drive") in profile.hooks
        assert ("callback", "unload_started") in profile.hooks


class TestTimeouts:
    def test_a_dock_step_that_takes_too_long_goes_back_to_search(self) -> None:
        """docking.position times out after DOCK_STEP_TIMEOUT_S (virtual time): a failure."""
        async def body(rig: Rig) -> tuple[str, float]:
            loop = asyncio.get_running_loop()
            await rig.machine.trigger("go_dock")
            for trigger in TO_POSITION:
                await rig.machine.trigger(trigger)
            start = loop.time()
            rig.moved.clear()
            await rig.moved.wait()
            return rig.machine.state, loop.time() - start

        state, waited_s = run_with(DockingIdle(), body)
        assert state == "docking.search.wall_follow"
        assert waited_s == DOCK_STEP_TIMEOUT_S

    def test_a_timeout_does_not_fire_into_a_state_entered_since(self) -> None:
        """Leaving a timed state cancels its timeout: nothing happens at the old deadline."""
        async def body(rig: Rig) -> str:
            await rig.machine.trigger("go_dock")
            for trigger in TO_POSITION:
                await rig.machine.trigger(trigger)
            await rig.machine.trigger("front_seen")
            await rig.machine.trigger("centered")
            await asyncio.sleep(DOCK_STEP_TIMEOUT_S - 1)
            await rig.machine.trigger("overlap_reached")
            await asyncio.sleep(DOCK_STEP_TIMEOUT_S - 2)
            return rig.machine.state

        assert run_with(DockingIdle(), body) == "docking.approach.front_beam_detect"

    def test_the_third_failure_falls_back_and_spent_fallbacks_end_in_recovery(self) -> None:
        """Section 4: under 3 failures retry, at 3 fall back to wall following (count reset);
        after docking.max_fallbacks (2) fallbacks the next one is refused: recovery."""
        async def body(rig: Rig) -> tuple[list[str], list[dict[str, Any]]]:
            await rig.machine.trigger("go_dock")
            seen = []
            for _ in range(9):
                state = rig.machine.state
                if state == "docking.dock.retry":
                    assert await rig.machine.trigger("backed_off")
                path = TO_DOCK if state.startswith("docking.search") else FROM_ALIGN
                for trigger in path:
                    assert await rig.machine.trigger(trigger), trigger
                await rig.machine.trigger("voltage_abnormal", reason="contacts at 6500 mV")
                seen.append(rig.machine.state)
            return seen, [f for k, f in rig.events if k == "dock.result"]

        states, results = run_with(DockingIdle(), body)
        retry, fallback = "docking.dock.retry", "docking.search.wall_follow"
        assert states == [retry, retry, fallback] * 2 + [retry, retry, "recovery"]
        assert [r["error_code"] for r in results] == [906] * 9
        assert [r["retries"] for r in results] == [1, 2, 3] * 3
        assert all(r["success"] is False for r in results)


class TestStateTasks:
    def test_a_state_task_runs_while_its_state_is_active(self) -> None:
        """Started on entering mission.drive, cancelled on leaving it."""
        log: list[str] = []

        async def drive(ctx: RobotContext) -> None:
            log.append("started")
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                log.append("cancelled")
                raise

        async def body(rig: Rig) -> str:
            await rig.machine.trigger("start_mission")
            await asyncio.sleep(1)
            await rig.machine.trigger("arrived")
            await asyncio.sleep(0)
            return rig.machine.state

        assert run_with(DriveProfile(drive), body) == "mission.unload"
        assert log == ["started", "cancelled"]

    def test_a_task_may_fire_the_trigger_that_ends_its_own_state(self) -> None:
        async def drive(ctx: RobotContext) -> None:
            await asyncio.sleep(5)
            await ctx.trigger("arrived")

        async def body(rig: Rig) -> str:
            await rig.machine.trigger("start_mission")
            await asyncio.sleep(10)
            return rig.machine.state

        assert run_with(DriveProfile(drive), body) == "mission.unload"

    def test_a_failing_behaviour_sends_the_robot_to_recovery(self) -> None:
        """An exception in a state task is an event and a ``fault``, not a crash."""
        async def drive(ctx: RobotContext) -> None:
            await asyncio.sleep(1)
            msg = "wheel jammed"
            raise RuntimeError(msg)

        events: list[Any] = []

        async def body(rig: Rig) -> str:
            await rig.machine.trigger("start_mission")
            await asyncio.sleep(2)
            events.extend(rig.events)
            return rig.machine.state

        assert run_with(DriveProfile(drive), body) == "recovery"
        assert events[0][0] == "behaviour"
        assert "wheel jammed" in events[0][1]["error"]

    def test_a_search_that_finds_no_beam_ends_in_recovery(self) -> None:
        """Each search times out (904); 3 of them fall back; with the fallbacks spent the
        robot goes to recovery: 9 searches of DOCK_SEARCH_TIMEOUT_S."""
        async def body(rig: Rig) -> tuple[str, float, list[int]]:
            loop = asyncio.get_running_loop()
            await rig.machine.trigger("go_dock")
            while rig.machine.state != "recovery":
                rig.moved.clear()
                await rig.moved.wait()
            codes = [f["error_code"] for k, f in rig.events if k == "dock.result"]
            return rig.machine.state, loop.time(), codes

        state, t_s, codes = run_with(DockingIdle(), body)
        assert state == "recovery"
        assert t_s == pytest.approx(9 * DOCK_SEARCH_TIMEOUT_S)
        assert codes == [904] * 9


class TestDriver:
    def test_cancelling_the_driver_mid_transition_stops_it(self) -> None:
        """The machine service ends when cancelled, even inside a transition's callbacks."""
        async def body(rig: Rig) -> bool:
            assert rig.task is not None
            rig.moved.clear()
            rig.machine.post("go_dock")
            await rig.moved.wait()  # set from inside the transition
            rig.task.cancel()
            await asyncio.wait({rig.task}, timeout=5)
            return rig.task.done()

        assert run_with(DockingIdle(), body) is True


class TestInvalidTransition:
    """The delivery seed's error table: an invalid transition is logged as an error, the state
    is kept, and a recovery is attempted."""

    def test_a_refused_trigger_is_an_error_and_the_state_is_kept(self) -> None:
        import structlog

        async def body(rig: Rig) -> tuple[bool, str, list[dict[str, Any]]]:
            with structlog.testing.capture_logs() as logs:
                fired = await rig.machine.trigger("arrived")  # idle has no such arrow
            return fired, rig.machine.state, logs

        fired, state, logs = run_with(DriveProfile(), body)
        assert fired is False and state == "idle"
        refused = [e for e in logs if e["event"] == "state.refused"]
        assert refused and refused[0]["log_level"] == "error"
        assert refused[0]["trigger"] == "arrived" and "start_mission" in refused[0]["allowed"]

    def test_a_task_that_ended_on_a_refused_trigger_is_started_again_once(self) -> None:
        """A state task fires a trigger its state refuses and ends: the robot would sit in a
        state nothing drives. The task is started again (once per entry): here the second
        run fires the right trigger."""
        runs: list[str] = []

        async def drive(ctx: RobotContext) -> None:
            runs.append(ctx.state)
            await ctx.trigger("arrived" if len(runs) > 1 else "start_mission")

        async def body(rig: Rig) -> str:
            assert await rig.machine.trigger("start_mission")
            for _ in range(20):
                await asyncio.sleep(0.05)
            return rig.machine.state

        assert run_with(DriveProfile(drive), body) == "mission.unload"
        assert runs == ["mission.drive", "mission.drive"]

    def test_a_task_that_keeps_firing_refused_triggers_is_not_restarted_for_ever(self) -> None:
        runs: list[str] = []

        async def drive(ctx: RobotContext) -> None:
            runs.append(ctx.state)
            await ctx.trigger("start_mission")

        async def body(rig: Rig) -> str:
            assert await rig.machine.trigger("start_mission")
            for _ in range(20):
                await asyncio.sleep(0.05)
            return rig.machine.state

        assert run_with(DriveProfile(drive), body) == "mission.drive"
        assert len(runs) == 2
