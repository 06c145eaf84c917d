"""The cabinet robot's state table: every phase and case of the seed by name, every callback
defined, and the machine runs through a whole task on it."""

from __future__ import annotations

import asyncio
from typing import Any

from behaviours.context import RobotContext
from behaviours.machine import MachineModel, RobotMachine
from behaviours.machine_tables import CORE_TRANSITIONS, callback_names, root_states
from behaviours.profile import BaseProfile
from behaviours.profiles.cabinet.states import cabinet_states, cabinet_transitions
from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults
from sim import vclock

SEED_CHECKLIST = {
    # The seed's init blocks, fitting cases 1-4 and relocate cases 1-5, by name.
    "mission.init": ["task_manager", "perceptor", "path_planner", "drive_controller"],
    "mission.fitting": ["fit", "change_orientation", "drive", "go_room_middle"],
    "mission.relocate": ["create_path", "proceed_path", "drive_to_node", "break_link",
                         "reset_links"],
    "mission.cabinet_action": ["face_front", "approach", "act", "report", "back_off"],
}


class TablesProfile(BaseProfile):
    name = "cabinet-tables"

    def mission_states(self) -> list[str | dict[str, Any]]:
        return cabinet_states()

    def mission_transitions(self) -> list[dict[str, Any]]:
        return cabinet_transitions()


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)


def run_trace(triggers: list[str]) -> list[str]:
    """The state after each trigger, on a real RobotMachine with the cabinet tables."""
    async def main() -> list[str]:
        ctx = RobotContext(Devices(), Settings(defaults()), DictStore(), system_wall_clock,
                           lambda kind, **f: None)

        async def stop() -> None:
            return None

        machine = RobotMachine(TablesProfile(), ctx, on_transition=lambda *a: None,
                               stop_motors=stop)
        task = asyncio.create_task(machine.run(lambda: None))
        await asyncio.sleep(0)
        states = []
        try:
            for name in ["booted", "start_mission", *triggers]:
                assert await machine.trigger(name), f"{name} refused in {machine.state}"
                states.append(machine.state)
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        return states

    return vclock.run(main())


class TestCabinetTables:
    def test_every_seed_phase_and_case_is_present_by_name(self) -> None:
        """The checklist: the seed's phases and cases, and failed, nest under mission."""
        by_name = {s["name"]: s for s in cabinet_states() if isinstance(s, dict)}
        for phase, cases in SEED_CHECKLIST.items():
            children = [c["name"] for c in by_name[phase.split(".")[1]]["children"]]
            assert children == cases
        assert "failed" in by_name

    def test_every_step_has_a_named_timeout(self) -> None:
        """Each step has a timeout, and a transition for it."""
        timed = [f"mission.{s['name']}.{c['name']}" for s in cabinet_states()
                 if isinstance(s, dict) for c in s.get("children", [])]
        assert all(timed)
        sources: set[str] = set()
        for t in cabinet_transitions():
            if t["trigger"] == "timeout":
                sources |= set([t["source"]] if isinstance(t["source"], str) else t["source"])
        assert sorted(set(timed) - sources) == []

    def test_every_callback_named_exists(self) -> None:
        """Callbacks in the cabinet tables are the machine model's."""
        names = callback_names(root_states(cabinet_states()),
                               [*CORE_TRANSITIONS, *cabinet_transitions()])
        assert sorted(n for n in names if not hasattr(MachineModel, n)) == []

    def test_a_whole_task_with_a_broken_link_and_a_reset(self) -> None:
        """init, a failed fit and a turn, a blocked link broken, no path, reset, arrival,
        action, then the task list is done."""
        trace = run_trace([
            "tasks_read", "map_read", "graph_built", "controllers_ready",
            "no_fit", "orientation_set", "driven", "fitted",
            "path_found", "next_node", "blocked", "link_broken",
            "no_path_links_broken", "links_reset", "path_found", "next_node", "node_reached",
            "path_done", "faced", "at_standoff", "acted", "reported", "mission_done"])
        assert trace[:3] == ["idle", "mission.init.task_manager", "mission.init.perceptor"]
        assert "mission.fitting.change_orientation" in trace
        assert "mission.relocate.break_link" in trace
        assert "mission.relocate.reset_links" in trace
        assert trace[-2] == "mission.cabinet_action.back_off"
        assert trace[-1] == "idle"

    def test_no_path_with_nothing_broken_fails(self) -> None:
        """No path and nothing to reset: mission.failed (wheels stopped on enter)."""
        trace = run_trace(["tasks_read", "map_read", "graph_built", "controllers_ready",
                           "fitted", "no_path"])
        assert trace[-1] == "mission.failed"

    def test_no_fit_after_the_room_middle_goes_to_recovery(self) -> None:
        """A full turn, the room's middle, another full turn: recovery."""
        trace = run_trace(["tasks_read", "map_read", "graph_built", "controllers_ready",
                           "full_turn", "room_middle_set", "driven", "no_fit_anywhere"])
        assert "mission.fitting.go_room_middle" in trace
        assert trace[-1] == "recovery"
