"""The cabinet robot's names (issue 26): each step of its phases has its task, and the state and
trigger constants are the tables'."""

from __future__ import annotations

from typing import Any

import pytest
from state_tasks_check import state_task_problems

from behaviours.machine_tables import CoreTrigger, RootState, state_paths
from behaviours.profiles.cabinet import states
from behaviours.profiles.cabinet.profile import CabinetProfile
from behaviours.profiles.cabinet.states import CabinetState, CabinetTrigger

WAITING = (CabinetState.FAILED,)
"""Waits for a person's ``acknowledged``, wheels stopped: no task on purpose."""


def _constants(cls: type) -> set[str]:
    return {v for k, v in vars(cls).items() if k.isupper()}


def _renamed(table: list[Any], phase: str, old: str, new: str) -> list[Any]:
    """The mission's states with step ``old`` of ``phase`` renamed ``new`` (a typo)."""
    def rename(children: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{**c, "name": new} if c["name"] == old else c for c in children]

    return [{**item, "children": rename(item["children"])}
            if isinstance(item, dict) and item["name"] == phase else item for item in table]


class TestStateTasks:
    def test_every_step_has_its_task(self) -> None:
        profile = CabinetProfile()
        assert state_task_problems(profile.mission_states(), profile.state_tasks(),
                                   WAITING) == []

    def test_a_misspelt_step_or_a_missing_task_is_reported(self) -> None:
        profile = CabinetProfile()
        table = _renamed(profile.mission_states(), "relocate", "break_link", "brake_link")
        assert state_task_problems(table, profile.state_tasks(), WAITING) == [
            "mission.relocate.brake_link: no state task",
            "mission.relocate.break_link: a task for no leaf of the mission"]
        tasks = profile.state_tasks()
        del tasks[CabinetState.REPORT]
        assert state_task_problems(profile.mission_states(), tasks, WAITING) == [
            "mission.cabinet_action.report: no state task"]
        assert state_task_problems(profile.mission_states(), profile.state_tasks()) == [
            "mission.failed: no state task"]


class TestConstants:
    def test_every_state_constant_is_a_state_of_the_table_and_back(self) -> None:
        paths = set(state_paths(states.cabinet_states(), RootState.MISSION))
        assert paths == _constants(CabinetState)

    def test_every_trigger_constant_is_a_trigger_of_the_table_and_back(self) -> None:
        used = {t["trigger"] for t in states.cabinet_transitions()}
        assert used - _constants(CabinetTrigger) == {CoreTrigger.TIMEOUT}
        assert _constants(CabinetTrigger) <= used

    def test_a_step_under_the_wrong_phase_is_refused(self) -> None:
        with pytest.raises(ValueError, match=r"not a step of 'mission\.fitting'"):
            states._phase(CabinetState.FITTING, {CabinetState.FIT: 1.0,
                                                 CabinetState.CREATE_PATH: 1.0})
