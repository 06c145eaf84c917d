"""Docking as a capability in the real machine: the watch (a lost dock IR device, a lost beam),
the counts and 'docked' across a restart, carrying on charging after one."""

from __future__ import annotations

import asyncio
from typing import Any

from docking_doubles import DictStore, Rig

from behaviours.context import RobotContext
from behaviours.docking.attempts import DockAttempts
from behaviours.docking.capability import Docking
from behaviours.machine import RobotMachine
from behaviours.machine_part import MachinePart
from behaviours.profile import BaseProfile, StateTask
from hal.readings import DockContacts
from sim import vclock


class DockingRobot(BaseProfile):
    """A robot with nothing but the docking capability."""

    name = "docker"

    def __init__(self, rig: Rig) -> None:
        self.docking = Docking(lambda: rig.odometry)

    def machine_parts(self, ctx: RobotContext) -> tuple[MachinePart, ...]:
        return (self.docking.machine_part(ctx),)

    def state_tasks(self) -> dict[str, StateTask]:
        return self.docking.state_tasks()


def _with_machine(rig: Rig, body: Any) -> Any:
    async def main() -> Any:
        rig.wheels.start_plant()
        stops: list[float] = []

        async def stop() -> None:
            stops.append(asyncio.get_running_loop().time())
            await rig.wheels.stop()

        transitions: list[tuple[str, str, str]] = []
        profile = DockingRobot(rig)
        machine = RobotMachine(profile, rig.ctx, on_transition=lambda *t: transitions.append(t),
                               stop_motors=stop)
        task = asyncio.create_task(machine.run(lambda: None))
        await asyncio.sleep(0)
        await machine.trigger("booted")
        try:
            return await body(machine, profile, transitions, stops)
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)

    return vclock.run(main())


class TestWatch:
    def test_losing_the_dock_ir_device_while_docking_is_recovery_with_motors_stopped(
            self) -> None:
        rig = Rig("boot")
        rig.ir.see(omni=("far_left",))

        async def body(machine: RobotMachine, _p: Any, transitions: list[Any],
                       stops: list[float]) -> tuple[str, int, Any]:
            await machine.trigger("go_dock")
            await asyncio.sleep(3.0)
            rig.ir.lost()  # the readings stop coming
            lost_at = asyncio.get_running_loop().time()
            await asyncio.sleep(5.0)
            after = [s for s in stops if s >= lost_at]
            return machine.state, len(after), [e for e in rig.events
                                               if e[0] == "dock.gave_up"]

        state, stops_after, gave_up = _with_machine(rig, body)
        assert state == "recovery"
        assert stops_after >= 1
        assert "dock IR receivers: no reading" in gave_up[0][1]["reason"]

    def test_a_robot_without_the_dock_ir_device_cannot_dock(self) -> None:
        rig = Rig("boot")
        rig.ctx.devices.dock_ir = None

        async def body(machine: RobotMachine, *_: Any) -> str:
            await machine.trigger("go_dock")
            await asyncio.sleep(1.0)
            return machine.state

        assert _with_machine(rig, body) == "recovery"


class TestRestart:
    def test_the_counts_survive_a_restart(self) -> None:
        store = DictStore()
        one = DockAttempts(lambda *_a, **_k: None, store)
        one.start(0.0)
        one.failed("voltage_abnormal", "docking.dock.voltage_detect", 10.0)
        one.failed("voltage_abnormal", "docking.dock.voltage_detect", 20.0)
        one.fell_back()
        two = DockAttempts(lambda *_a, **_k: None, store)
        assert (two.counts.failures, two.counts.fallbacks, two.counts.attempts) == (0, 1, 2)

    def test_a_docked_robot_carries_on_charging_after_a_restart(self) -> None:
        rig = Rig("boot")
        rig.contacts.value = DockContacts(16_500, 0.0)
        rig.store.put("docking.dock", {"version": 1, "values": {"docked": True}})

        async def body(machine: RobotMachine, profile: Any, *_: Any) -> tuple[bool, str]:
            resumed = await profile.docking.resume_if_docked(rig.ctx)
            return resumed, machine.state

        assert _with_machine(rig, body) == (True, "docking.charging")

    def test_no_voltage_after_a_restart_means_not_docked(self) -> None:
        rig = Rig("boot")
        rig.store.put("docking.dock", {"version": 1, "values": {"docked": True}})

        async def body(machine: RobotMachine, profile: Any, *_: Any) -> tuple[bool, str]:
            resumed = await profile.docking.resume_if_docked(rig.ctx)
            return resumed, machine.state

        assert _with_machine(rig, body) == (False, "idle")
        assert rig.store["docking.dock"]["values"]["docked"] is False
