"""The line-following loop in time: the 13 FPS grid, overruns, link loss, live tuning,
colours, and what the behaviour may import."""

from __future__ import annotations

import asyncio
import contextlib

import numpy as np
import pytest
from follow_doubles import (
    WIDTH,
    make,
    run_for,
)

from sim import vclock


class TestLoop:
    def test_ticks_keep_the_13_fps_period_on_loop_time(self) -> None:
        """Commands go out every 1/13 s, on a grid that does not drift."""
        follower, _, motors, _ = make()
        vclock.run(run_for(follower, 9.99))
        times = np.array([t for t, _ in motors.commands])
        assert len(times) == 130
        assert np.allclose(np.diff(times), 1 / 13, atol=1e-9)
        assert times[-1] == pytest.approx(129 / 13)
        assert follower.overruns == 0
        assert follower.status()["fps"] == pytest.approx(13.0)

    def test_slow_ticks_are_counted_as_overruns_and_the_grid_is_kept(self) -> None:
        """A drive() taking 100 ms overruns a 77 ms period; later ticks stay on the grid."""
        follower, _, motors, _ = make()
        motors.delay_s = 0.1
        vclock.run(run_for(follower, 2.0))
        assert follower.overruns > 5
        assert follower.status()["overruns"] == follower.overruns

    def test_the_rate_is_tunable_live(self) -> None:
        """line_follow.fps = 20 while running: ticks 50 ms apart from then on."""
        follower, _, motors, settings = make()

        async def main() -> None:
            task = asyncio.create_task(follower.run())
            await asyncio.sleep(1.0)
            settings.set("line_follow.fps", 20)
            await asyncio.sleep(1.0)
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

        vclock.run(main())
        gaps = np.diff([t for t, _ in motors.commands][-10:])
        assert np.allclose(gaps, 0.05, atol=1e-9)

    def test_the_loop_rides_out_a_motor_link_outage(self) -> None:
        """LinkDown for 1 s: counted and logged, the loop goes on, commands resume."""
        follower, _, motors, _ = make()

        async def main() -> None:
            task = asyncio.create_task(follower.run())
            await asyncio.sleep(1.0)
            motors.unplug()
            await asyncio.sleep(1.0)
            motors.plug_in()
            await asyncio.sleep(1.0)
            assert not task.done()
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

        vclock.run(main())
        assert follower.link_down_count == 13
        times = [t for t, _ in motors.commands]
        assert any(t > 2.0 for t in times)
        assert motors.stops == 1

    def test_cancelling_stops_the_wheels(self) -> None:
        """The state leaving line following cancels the task: STOP goes out."""
        follower, _, motors, _ = make()
        vclock.run(run_for(follower, 0.5))
        assert motors.stops == 1
        assert follower.status()["state"] == "stopped"

    def test_status_has_the_figures_a_technician_reads(self) -> None:
        """error_px, fps, overruns, lost count, latency and the last command."""
        follower, camera, _, _ = make()
        camera.show(WIDTH / 2 + 40)
        vclock.run(run_for(follower, 1.0))
        status = follower.status()
        assert status["error_px"] == pytest.approx(40, abs=1.5)
        for key in ("fps", "overruns", "lost_count", "lost_total", "latency_p99_ms",
                    "late_p99_ms", "command", "colour", "band", "state"):
            assert key in status


class TestColour:
    def test_the_servers_colour_is_followed_and_null_restores_the_default(self) -> None:
        """FollowColor 'Red' -> red; null -> the configured line_follow.colour."""
        follower, *_ = make(colour="blue")
        assert follower.tracker.colour == "blue"
        assert follower.set_follow_colour("Red")
        assert follower.tracker.colour == "red"
        assert follower.set_follow_colour(None)
        assert follower.tracker.colour == "blue"

    def test_an_unknown_colour_is_ignored_and_the_robot_keeps_going(self) -> None:
        """FollowColor 'purple': logged, refused, the current colour stays."""
        follower, *_ = make()
        assert not follower.set_follow_colour("purple")
        assert follower.tracker.colour == "black"

    def test_the_configured_colour_is_tunable_live_without_a_server_colour(self) -> None:
        """tune set line_follow.colour red: followed at once (the server named none)."""
        follower, _, _, settings = make()
        unwatch = settings.watch("line_follow", follower._on_setting)
        settings.set("line_follow.colour", "red")
        assert follower.tracker.colour == "red"
        unwatch()


class TestLayering:
    @pytest.mark.parametrize("module", ["behaviours/line/follow.py",
                                        "behaviours/line/tracker.py",
                                        "behaviours/line/colours.py"])
    def test_the_behaviour_imports_no_driver_and_no_simulator(self, module: str) -> None:
        """Behaviours see hal interfaces only: no drivers, no sim, no frame capture."""
        import ast
        from pathlib import Path

        root = Path(__file__).resolve().parents[3]
        tree = ast.parse((root / module).read_text())
        names = [alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names]
        names += [node.module or "" for node in ast.walk(tree)
                  if isinstance(node, ast.ImportFrom)]
        assert not [n for n in names if n.startswith(("drivers", "sim", "picamera2"))]
        assert "VideoCapture" not in (root / module).read_text()
