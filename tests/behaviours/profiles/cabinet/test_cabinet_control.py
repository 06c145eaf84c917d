"""The cabinet profile's control methods and status: the links listed with their state, a
reset by hand opens them (not counted against the task's budget), the mission shown."""

from __future__ import annotations

from typing import Any

import pytest
from cabinet_site_fixture import site_doc, tasks_doc

from behaviours.motion.odometry import Odometry
from behaviours.profile import ControlRefused
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.map_reader import parse_site_map
from behaviours.profiles.cabinet.profile import CabinetProfile
from behaviours.profiles.cabinet.site import build_site
from behaviours.profiles.cabinet.steps.mission import Mission
from behaviours.profiles.cabinet.task_list import parse_task_list


class _Ctx:
    def __init__(self) -> None:
        self.events: list[tuple[str, dict[str, Any]]] = []

    def emit(self, kind: str, **fields: Any) -> None:
        self.events.append((kind, fields))


def _profile() -> CabinetProfile:
    config = CabinetConfig()
    site_map = parse_site_map(site_doc(), "site.json")
    tasks = parse_task_list(tasks_doc(), "tasks.json", site_map)
    profile = CabinetProfile()
    profile.mission = Mission(config, Odometry(0.3, 0.035, 1000))
    profile.mission.site = build_site(site_map, tasks, config, "site.json")
    profile.mission.remaining = list(tasks.tasks)
    return profile


async def test_links_are_listed_and_reset_by_hand() -> None:
    """cabinet.links shows a broken link as closed; cabinet.reset_links opens it."""
    profile = _profile()
    assert profile.mission is not None and profile.mission.site is not None
    graph = profile.mission.site.graph
    assert graph.break_link("door:ab:a", "door:ab:b")
    ctx = _Ctx()
    methods = profile.control_methods(ctx)  # type: ignore[arg-type]
    listed = await methods["cabinet.links"]({})
    assert listed["broken"] == [["door:ab:a", "door:ab:b"]]
    row = next(r for r in listed["links"] if r[:2] == ["door:ab:a", "door:ab:b"])
    assert row[3] is False
    assert await methods["cabinet.reset_links"]({}) == {"opened": 1}
    assert not graph.broken and graph.resets_this_task == 0
    assert ctx.events[-1][0] == "links.reset"


async def test_links_before_the_map_is_read_are_refused() -> None:
    """No map read yet: a clear refusal, not an exception from deep inside."""
    profile = CabinetProfile()
    methods = profile.control_methods(_Ctx())  # type: ignore[arg-type]
    with pytest.raises(ControlRefused, match="not read yet"):
        await methods["cabinet.links"]({})


def test_mission_status_shows_tasks_path_and_broken_links() -> None:
    """robotctl status's mission: the tasks left, the path, the broken links."""
    profile = _profile()
    assert profile.mission is not None and profile.mission.site is not None
    profile.mission.path = ["door:ab:a", "door:ab:b", "cabinet:c2"]
    profile.mission.site.graph.break_link("room:lab", "door:ab:a")
    status = profile.mission_status()
    assert status["tasks"] == ["c2", "c4", "c3", "c1"]
    assert status["path"] == ["door:ab:a", "door:ab:b", "cabinet:c2"]
    assert status["broken_links"] == [["door:ab:a", "room:lab"]]
