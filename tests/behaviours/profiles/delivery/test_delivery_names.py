"""RelayBot's names (issue 26): each of the nine states has its task, and the trigger constants
are the tables' triggers."""

from __future__ import annotations

from typing import Any

from state_tasks_check import state_task_problems

from behaviours.machine_tables import CoreTrigger
from behaviours.profiles.delivery import states
from behaviours.profiles.delivery.profile import DeliveryProfile
from behaviours.profiles.delivery.states import DeliveryTrigger


def _constants(cls: type) -> set[str]:
    return {v for k, v in vars(cls).items() if k.isupper()}


def _renamed(table: list[Any], old: str, new: str) -> list[Any]:
    """The mission's states with ``old`` renamed ``new`` (a typo in the table)."""
    return [new if s == old else {**s, "name": new}
            if isinstance(s, dict) and s["name"] == old else s for s in table]


class TestStateTasks:
    def test_each_of_the_nine_states_has_its_task(self) -> None:
        profile = DeliveryProfile()
        assert state_task_problems(profile.mission_states(), profile.state_tasks()) == []

    def test_a_misspelt_state_is_reported(self) -> None:
        """The check fails: a table whose ``loading`` is misspelt, a task dict without one."""
        profile = DeliveryProfile()
        table = _renamed(profile.mission_states(), states.LOADING, "loadnig")
        tasks = profile.state_tasks()
        assert state_task_problems(table, tasks) == [
            "mission.loadnig: no state task",
            "mission.loading: a task for no leaf of the mission"]
        del tasks["mission.resetting"]
        assert state_task_problems(profile.mission_states(), tasks) == [
            "mission.resetting: no state task"]


class TestTriggers:
    def test_the_constants_are_the_tables_triggers(self) -> None:
        used = {t["trigger"] for t in DeliveryProfile().mission_transitions()}
        assert used - _constants(DeliveryTrigger) == {CoreTrigger.TIMEOUT}
        assert _constants(DeliveryTrigger) <= used
