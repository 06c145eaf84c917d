"""What ``robotd sim`` prints while it runs."""

from __future__ import annotations

import io

from sim.console import SimConsole


class TestTransitions:
    def test_a_lone_robot_is_named_like_the_other_lines_of_its_run(self) -> None:
        """One robot or several, each transition line says whose it is."""
        out = io.StringIO()
        SimConsole(stream=out).transition(5.41, "laundry-1", "idle", "mission.to_room",
                                          "go_room")
        assert out.getvalue() == "[    5.41 s] laundry-1: idle -> mission.to_room  (go_room)\n"

    def test_quiet_prints_no_transitions(self) -> None:
        out = io.StringIO()
        SimConsole(quiet=True, stream=out).transition(1.0, "r", "boot", "idle", "booted")
        assert out.getvalue() == ""
