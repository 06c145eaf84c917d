"""The smaller profiles' mission states each have their task (issue 26; delivery and cabinet
have tests of their own), and their state constants are their tables'."""

from __future__ import annotations

import pytest
from state_tasks_check import state_task_problems

from behaviours.machine_tables import mission_children
from behaviours.profile import BaseProfile
from behaviours.profiles.laundry.profile import LaundryProfile
from behaviours.profiles.laundry.states import WAITING, LaundryState, LaundryTrigger
from behaviours.profiles.patrol.profile import PatrolProfile, PatrolState, PatrolTrigger
from behaviours.profiles.square.profile import SQUARE, SquareProfile
from behaviours.profiles.vacuum.profile import VacuumProfile, VacuumState, VacuumTrigger

PROFILES = [PatrolProfile, SquareProfile, VacuumProfile]


def _constants(cls: type) -> set[str]:
    return {v for k, v in vars(cls).items() if k.isupper()}


@pytest.mark.parametrize("profile_cls", PROFILES, ids=[p.name for p in PROFILES])
def test_every_mission_state_has_its_task(profile_cls: type[BaseProfile]) -> None:
    profile = profile_cls()
    assert state_task_problems(profile.mission_states(), profile.state_tasks()) == []


@pytest.mark.parametrize(("profile_cls", "states", "triggers"), [
    (PatrolProfile, _constants(PatrolState), _constants(PatrolTrigger)),
    (SquareProfile, {SQUARE}, set()),
    (VacuumProfile, _constants(VacuumState), _constants(VacuumTrigger)),
], ids=["patrol", "square", "vacuum"])
def test_the_constants_are_the_tables(profile_cls: type[BaseProfile], states: set[str],
                                      triggers: set[str]) -> None:
    profile = profile_cls()
    assert {f"mission.{s}" for s in profile.mission_states()} == states
    assert {t["trigger"] for t in profile.mission_transitions()} == triggers


def test_laundry_follows_the_line_in_each_moving_state_and_waits_in_the_others() -> None:
    profile = LaundryProfile()
    assert state_task_problems(profile.mission_states(), profile.state_tasks(),
                               waiting=WAITING) == []


def test_laundrys_constants_are_its_tables() -> None:
    profile = LaundryProfile()
    assert ({f"mission.{s}" for s in profile.mission_states()}
            == _constants(LaundryState))
    transitions = profile.mission_transitions()
    assert {t["trigger"] for t in transitions} == _constants(LaundryTrigger)
    named = {t["dest"] for t in transitions}
    for t in transitions:
        named |= set(t["source"]) if isinstance(t["source"], list) else {t["source"]}
    assert named - {"idle"} == _constants(LaundryState)


def test_a_mission_state_the_tasks_miss_is_reported() -> None:
    profile = PatrolProfile()
    tasks = profile.state_tasks()
    del tasks[PatrolState.AT_GOAL]
    tasks["mission.at_gaol"] = tasks[PatrolState.PLAN]
    assert state_task_problems(profile.mission_states(), tasks) == [
        "mission.at_goal: no state task", "mission.at_gaol: a task for no leaf of the mission"]


def test_mission_children_takes_only_paths_directly_under_mission() -> None:
    assert mission_children("mission.plan", "mission.at_goal") == ["plan", "at_goal"]
    with pytest.raises(ValueError, match="not a state directly under 'mission'"):
        mission_children("mission.fitting.fit")
    with pytest.raises(ValueError, match="not a state directly under 'mission'"):
        mission_children("plan")
