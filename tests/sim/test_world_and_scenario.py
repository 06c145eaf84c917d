"""Scenario files and the world they describe: loaded, and errors that name the key."""

from __future__ import annotations

import pytest

from sim.scenario import ScenarioError, builtin_names, load_scenario, parse_scenario
from sim.world.floor_plan import World, WorldError


class TestWorld:
    def test_boundary_walls_enclose_the_floor(self) -> None:
        world = World.from_table({"width_m": 3, "height_m": 2})
        assert world.walls.shape == (4, 4)
        assert world.clearance_m(1.5, 1.0) == pytest.approx(1.0)

    def test_cross_track_is_distance_to_the_nearest_line(self) -> None:
        world = World.from_table({"width_m": 3, "height_m": 2, "lines": [
            {"points": [[0.5, 1.0], [2.5, 1.0]], "colour": "red"}]})
        assert world.cross_track_m(1.0, 1.2) == pytest.approx(0.2)

    def test_bad_colour_names_the_key(self) -> None:
        with pytest.raises(WorldError, match=r"world.lines\[0\].colour"):
            World.from_table({"width_m": 3, "height_m": 2,
                              "lines": [{"points": [[0, 0], [1, 1]], "colour": "mauve"}]})

    def test_missing_size_names_the_key(self) -> None:
        with pytest.raises(WorldError, match=r"world.width_m: required number is missing"):
            World.from_table({"height_m": 2})


class TestScenario:
    def test_square_is_built_in(self) -> None:
        assert "square" in builtin_names()
        scenario = load_scenario("square")
        assert scenario.profile == "square"
        assert scenario.success.final_poses[0].x_m == scenario.robots[0].x_m
        assert scenario.script[0].action == "mcu.unplug"

    def test_unknown_name_lists_the_built_ins(self) -> None:
        with pytest.raises(ScenarioError, match=r"built-in: .*square"):
            load_scenario("no-such-scenario")

    def test_syntax_error_names_the_source(self) -> None:
        with pytest.raises(ScenarioError, match=r"my.toml: TOML syntax error"):
            parse_scenario("[scenario\n", "my.toml")

    def test_unknown_body_parameter_is_named(self) -> None:
        text = """
[scenario]
name = "x"
[world]
width_m = 2
height_m = 2
[robot]
x_m = 1
y_m = 1
body = { wheel_size = 3 }
[success]
"""
        with pytest.raises(ScenarioError, match=r"robot.body.wheel_size: unknown key"):
            parse_scenario(text, "x.toml")

    def test_script_steps_are_sorted_by_time(self) -> None:
        text = """
[scenario]
[world]
width_m = 2
height_m = 2
[robot]
x_m = 1
y_m = 1
[[script]]
at_s = 5
action = "b"
[[script]]
at_s = 1
action = "a"
[success]
"""
        assert [s.action for s in parse_scenario(text, "x.toml").script] == ["a", "b"]


class TestUnknownKeys:
    """A typo in a scenario is an error naming the key, never silently ignored."""

    BASE = "[scenario]\n[world]\nwidth_m = 2\nheight_m = 2\n[robot]\nx_m = 1\ny_m = 1\n[success]\n"

    @pytest.mark.parametrize(("text", "message"), [
        (BASE + "time_limt_s = 3\n", r"success.time_limt_s: unknown key \(did you mean "
                                     r"'time_limit_s'\?\)"),
        (BASE.replace("[scenario]\n", "[scenario]\nsed = 3\n"), r"scenario.sed: unknown key"),
        (BASE.replace("y_m = 1\n", "y_m = 1\nheding_deg = 3\n"),
         r"robot.heding_deg: unknown key \(did you mean 'heading_deg'\?\)"),
        (BASE.replace("height_m = 2\n", "height_m = 2\nwals = []\n"),
         r"world.wals: unknown key \(did you mean 'walls'\?\)"),
        (BASE + "[[script]]\nat_s = 1\naction = 'mcu.unplug'\nduraton_s = 1\n",
         r"script\[0\].duraton_s: unknown key"),
        ("[scenrio]\n" + BASE, r"scenrio: unknown key \(did you mean 'scenario'\?\)"),
    ])
    def test_is_an_error_naming_the_key(self, text: str, message: str) -> None:
        with pytest.raises(ScenarioError, match=message):
            parse_scenario(text, "typo.toml")
