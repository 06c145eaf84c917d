"""Script actions of the navigation scenarios: lidar faults, person.walk, body.teleport."""

from __future__ import annotations

import math
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any, cast

import pytest

from sim.actions import ACTIONS, Step
from sim.devices.ld19 import SimLd19
from sim.scenario import Scenario, ScenarioError
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import Person, World
from sim.world.geometry import Pose, segments_array


def _step(action: str, args: dict[str, Any], *, ld19: SimLd19 | None = None,
          later: list[tuple[float, Callable[[], None], str]] | None = None,
          people: list[Person] | None = None) -> Step:
    world = World(4.0, 4.0, segments_array([(0, 0, 4, 0)]), people=people or [])
    body = DiffDriveBody(world, Pose(1.0, 1.0, 0.0))
    rig = SimpleNamespace(ld19=ld19, body=body)
    scenario = SimpleNamespace(world=world)
    pending = later if later is not None else []
    return Step(cast(Scenario, scenario), "sim-1", cast(Any, rig), args,
                lambda d, fn, name: pending.append((d, fn, name)))


def _do(action: str, step: Step) -> None:
    ACTIONS[action](step)


class TestLidarActions:
    async def test_corrupt_for_a_while(self) -> None:
        """lidar.corrupt sets the bit-flip rate; its end (after duration_s) clears it."""
        ld19 = SimLd19(lambda a: a * 0 + 1.0)
        later: list[tuple[float, Callable[[], None], str]] = []
        _do("lidar.corrupt", _step("lidar.corrupt", {"pct": 5, "duration_s": 2.0},
                                   ld19=ld19, later=later))
        assert ld19.corrupt_fraction == 0.05
        delay, end, name = later[0]
        assert (delay, name) == (2.0, "lidar.corrupt_end")
        end()
        assert ld19.corrupt_fraction == 0.0

    async def test_stall_and_unplug(self) -> None:
        """lidar.stall silences the sensor; lidar.unplug pulls it (and plugs it back)."""
        ld19 = SimLd19(lambda a: a * 0 + 1.0)
        later: list[tuple[float, Callable[[], None], str]] = []
        _do("lidar.stall", _step("lidar.stall", {"duration_s": 1.0}, ld19=ld19, later=later))
        assert ld19.stalled
        later[0][1]()
        assert not ld19.stalled
        _do("lidar.unplug", _step("lidar.unplug", {}, ld19=ld19))
        assert not ld19.plugged
        ld19.close()

    def test_a_robot_without_lidar_is_a_clear_error(self) -> None:
        """A lidar action on a robot without one names the robot."""
        with pytest.raises(ScenarioError, match="sim-1 has no LiDAR"):
            _do("lidar.stall", _step("lidar.stall", {}))


class TestWorldActions:
    async def test_person_walk_sets_a_path_from_where_they_stand(self) -> None:
        """person.walk starts at the person's place and walks the points at the speed."""
        person = Person("walker", 1.0, 3.0)
        _do("person.walk", _step("person.walk", {"name": "walker", "points": [[3.0, 3.0]],
                                                 "speed_mps": 0.5}, people=[person]))
        assert person.walk is not None
        assert person.walk.points[0] == (1.0, 3.0)
        start = person.walk.start_s
        person.update(start + 2.0)
        assert math.isclose(person.x_m, 2.0) and math.isclose(person.y_m, 3.0)

    def test_person_walk_needs_points(self) -> None:
        """Bad points are a ScenarioError that says what is expected."""
        with pytest.raises(ScenarioError, match="points"):
            _do("person.walk", _step("person.walk", {"name": "p", "points": 3},
                                     people=[Person("p", 0, 0)]))

    def test_teleport_absolute_and_relative(self) -> None:
        """body.teleport puts the body at x/y/heading, or moves it by dx/dy."""
        step = _step("body.teleport", {"x_m": 2.0, "y_m": 2.5, "heading_deg": 90})
        _do("body.teleport", step)
        pose = step.rig.body.pose
        assert (pose.x_m, pose.y_m) == (2.0, 2.5)
        assert math.isclose(pose.heading_rad, math.pi / 2)
        step = _step("body.teleport", {"dy_m": 1.0})
        ticks = step.rig.body.encoder_ticks()
        _do("body.teleport", step)
        assert step.rig.body.pose.y_m == 2.0
        assert step.rig.body.encoder_ticks() == ticks  # the wheels felt nothing
