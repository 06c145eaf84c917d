"""The line-following control loop: bands, PID, lost line, link loss, timing, live tuning."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.line_follow import LineFollower, LineLostError
from behaviours.line_tracker import LineReading
from hal.devices import LinkDown
from hal.readings import Frame, LinkStats, MotorCommand
from robotd import vclock
from robotd.config.loader import defaults
from robotd.config.settings import Settings

WIDTH, HEIGHT = 320, 240


def line_image(column: float | None) -> np.ndarray:  # type: ignore[type-arg]
    """A light floor with a 30 px dark line centred on ``column`` (None: bare floor)."""
    image = np.full((HEIGHT, WIDTH, 3), 200, np.uint8)
    if column is not None:
        lo, hi = max(0, round(column) - 15), min(WIDTH, round(column) + 15)
        image[:, lo:hi] = 30
    return image


class FreshCamera:
    """A camera with a new frame whenever asked; the test sets what it shows."""

    name = "camera"
    width_px = WIDTH
    height_px = HEIGHT

    def __init__(self, column: float | None = WIDTH / 2) -> None:
        self.image = line_image(column)
        self.seq = 0
        self.frozen = False

    def show(self, column: float | None) -> None:
        self.image = line_image(column)

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    async def stop(self) -> None:
        return None

    def status(self) -> dict[str, Any]:
        return {}

    def latest(self) -> Frame | None:
        if not self.frozen:
            self.seq += 1
        return Frame(self.image, self.seq, asyncio.get_running_loop().time())

    async def next_reading(self) -> Frame:
        await asyncio.Event().wait()  # a frozen camera never delivers
        raise AssertionError


class RecordingMotors:
    """Motors that record commands with their loop time; can be unplugged or made slow."""

    name = "motors"

    def __init__(self) -> None:
        self.commands: list[tuple[float, MotorCommand]] = []
        self.stops = 0
        self.connected = True
        self.delay_s = 0.0

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        return None

    def unplug(self) -> None:
        self.connected = False

    def plug_in(self) -> None:
        self.connected = True

    async def drive(self, command: MotorCommand) -> None:
        if self.delay_s:
            await asyncio.sleep(self.delay_s)
        if not self.connected:
            raise LinkDown("motor board link is down")
        self.commands.append((asyncio.get_running_loop().time(), command))

    async def stop(self) -> None:
        self.stops += 1

    def on_link_change(self, callback: Callable[[bool], None]) -> None:
        return None

    def link_stats(self) -> LinkStats:
        return LinkStats(connected=self.connected)

    def status(self) -> dict[str, Any]:
        return {}


def make(**overrides: Any) -> tuple[LineFollower, FreshCamera, RecordingMotors, Settings]:
    settings = Settings(defaults())
    for key, value in overrides.items():
        settings.set(f"line_follow.{key}", value)
    camera, motors = FreshCamera(), RecordingMotors()
    return LineFollower(camera, motors, settings), camera, motors, settings


def seen(error_px: float) -> LineReading:
    return LineReading(error_px, 1.0, False, WIDTH / 2 + error_px)


LOST = LineReading(0.0, 0.0, True, reason="no line")


async def run_for(follower: LineFollower, seconds: float) -> BaseException | None:
    task = asyncio.create_task(follower.run())
    await asyncio.sleep(seconds)
    if task.done():
        return task.exception()
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
    return None


class TestBands:
    @pytest.mark.parametrize(("error_px", "band"), [
        (10, "forward"), (50, "gentle"), (100, "strong"), (200, "full_turn"),
        (-10, "forward"), (-50, "gentle"), (-100, "strong"), (-200, "full_turn")])
    def test_the_error_picks_the_seeds_band(self, error_px: float, band: str) -> None:
        """< 30 px forward, 30-80 gentle, 80-150 strong, > 150 full turn."""
        follower, *_ = make()
        follower.decide(seen(error_px), WIDTH, 1 / 13)
        assert follower.status()["band"] == band

    def test_the_bands_are_pixels_of_the_configured_width(self) -> None:
        """A camera that delivers 640 px frames when camera.width is 320: a 100 px error there
        is 50 px of the configured frame, the gentle band, not the strong one."""
        follower, *_ = make()
        follower.decide(seen(100), 2 * WIDTH, 1 / 13)
        assert follower.status()["band"] == "gentle"

    def test_the_bands_slow_the_robot_down_as_the_error_grows(self) -> None:
        """Mean wheel duty falls from band to band; a full turn spins on the spot."""
        means = []
        for error_px in (10, 50, 100, 200):
            follower, *_ = make(kd=0.0)
            left, right = follower.decide(seen(error_px), WIDTH, 1 / 13).signed()
            means.append((left + right) / 2)
        assert means[0] > means[1] > means[2] > means[3]
        assert means[3] == pytest.approx(0.0, abs=0.01)

    def test_a_line_on_the_right_turns_the_robot_right(self) -> None:
        """Positive error: the left wheel runs faster (or forward while the right reverses)."""
        for error_px in (20, 60, 120, 180):
            follower, *_ = make()
            left, right = follower.decide(seen(error_px), WIDTH, 1 / 13).signed()
            assert left > right
            follower, *_ = make()
            left, right = follower.decide(seen(-error_px), WIDTH, 1 / 13).signed()
            assert right > left

    def test_band_edges_are_tunable_live(self) -> None:
        """Setting band_forward_px to 5 makes a 10 px error a gentle correction."""
        follower, _, _, settings = make()
        unwatch = settings.watch("line_follow", follower._on_setting)
        settings.set("line_follow.band_forward_px", 5)
        follower.decide(seen(10), WIDTH, 1 / 13)
        assert follower.status()["band"] == "gentle"
        unwatch()


    @settings(max_examples=50, deadline=None)
    @given(error_px=st.floats(-160, 160))
    def test_steering_is_mirror_symmetric(self, error_px: float) -> None:
        """A line as far left as another is right gives the same command, wheels swapped."""
        right, *_ = make()
        left, *_ = make()
        r = right.decide(seen(error_px), WIDTH, 1 / 13)
        mirrored = left.decide(seen(-error_px), WIDTH, 1 / 13)
        assert (r.left_pwm, r.right_pwm) == (mirrored.right_pwm, mirrored.left_pwm)


class TestPid:
    def test_the_integral_term_is_capped(self) -> None:
        """A steady error with ki > 0: the steering stops growing at max_integral (anti-windup)."""
        follower, *_ = make(kp=0.0, kd=0.0, ki=1.0, max_integral=0.1, speed=0.5)
        commands = [follower.decide(seen(20), WIDTH, 0.1).signed() for _ in range(200)]
        left, right = commands[-1]
        assert (left - right) / 2 == pytest.approx(0.1, abs=0.01)

    def test_the_integral_unwinds_when_the_error_changes_sign(self) -> None:
        """Capped, not accumulated past the cap: the other side is reached in few steps."""
        follower, *_ = make(kp=0.0, kd=0.0, ki=1.0, max_integral=0.1, speed=0.5)
        for _ in range(200):
            follower.decide(seen(20), WIDTH, 0.1)
        steps = 0
        while True:
            left, right = follower.decide(seen(-20), WIDTH, 0.1).signed()
            steps += 1
            if right > left:
                break
        assert steps < 20

    def test_the_derivative_damps_a_closing_error(self) -> None:
        """An error shrinking fast steers less than the same error standing still."""
        follower, *_ = make(kd=0.5)
        follower.decide(seen(28), WIDTH, 0.077)
        closing = follower.decide(seen(20), WIDTH, 0.077).signed()
        steady_follower, *_ = make(kd=0.5)
        steady_follower.decide(seen(20), WIDTH, 0.077)
        steady = steady_follower.decide(seen(20), WIDTH, 0.077).signed()
        assert closing[0] - closing[1] < steady[0] - steady[1]


class TestLostLine:
    def test_a_lost_line_turns_toward_where_it_was_last_seen(self) -> None:
        """Last seen on the left: spin left (right wheel forward, left backward)."""
        follower, *_ = make()
        follower.decide(seen(-60), WIDTH, 1 / 13)
        left, right = follower.decide(LOST, WIDTH, 1 / 13).signed()
        assert right > 0 > left
        assert follower.status()["state"] == "recovering"

    def test_twenty_lost_frames_are_tried_and_the_next_gives_up(self) -> None:
        """Lost counter > 20 (the seed's test): LineLostError, after 20 recovery turns."""
        follower, *_ = make()
        for _ in range(20):
            assert not follower.decide(LOST, WIDTH, 1 / 13).is_stop
        with pytest.raises(LineLostError, match="21 frames"):
            follower.decide(LOST, WIDTH, 1 / 13)

    def test_finding_the_line_resets_the_counter(self) -> None:
        """19 lost, 1 seen, 19 lost: still going."""
        follower, *_ = make()
        for _ in range(19):
            follower.decide(LOST, WIDTH, 1 / 13)
        follower.decide(seen(0), WIDTH, 1 / 13)
        for _ in range(19):
            follower.decide(LOST, WIDTH, 1 / 13)
        assert follower.lost_count == 19
        assert follower.lost_total == 38

    def test_run_stops_the_wheels_and_reports_the_loss(self) -> None:
        """The line vanishes: after 21 lost frames run() raises and the wheels get STOP."""
        follower, camera, motors, _ = make()

        async def main() -> BaseException | None:
            task = asyncio.create_task(follower.run())
            await asyncio.sleep(1.0)
            camera.show(None)
            await asyncio.sleep(5.0)
            assert task.done()
            return task.exception()

        error = vclock.run(main())
        assert isinstance(error, LineLostError)
        assert motors.stops == 1
        assert follower.status()["state"] == "lost"
        assert follower.status()["lost_count"] == 21

    def test_a_frame_the_tracker_cannot_read_counts_as_lost_and_the_loop_goes_on(self) -> None:
        """A grey (2-D) frame: no exception out of the loop; lost frames, counted, then the
        line comes back and is followed again."""
        follower, camera, _, _ = make()

        async def main() -> dict[str, Any]:
            task = asyncio.create_task(follower.run())
            await asyncio.sleep(0.5)
            camera.image = np.full((HEIGHT, WIDTH), 200, np.uint8)
            await asyncio.sleep(0.5)
            camera.show(WIDTH / 2)
            await asyncio.sleep(0.5)
            assert not task.done()
            status = follower.status()
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            return status

        status = vclock.run(main())
        assert status["bad_frames"] >= 5
        assert status["lost_total"] == status["bad_frames"]
        assert status["state"] == "following"

    def test_a_camera_that_stops_delivering_counts_as_lost(self) -> None:
        """No fresh frames: each tick is a lost frame; the robot stops after 21."""
        follower, camera, _, _ = make()
        camera.frozen = True
        error = vclock.run(run_for(follower, 5.0))
        assert isinstance(error, LineLostError)
        assert follower.frame_timeouts == 21


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
    @pytest.mark.parametrize("module", ["behaviours/line_follow.py",
                                        "behaviours/line_tracker.py"])
    def test_the_behaviour_imports_no_driver_and_no_simulator(self, module: str) -> None:
        """Behaviours see hal interfaces only: no drivers, no hal.sim, no frame capture."""
        import ast
        from pathlib import Path

        root = Path(__file__).resolve().parents[2]
        tree = ast.parse((root / module).read_text())
        names = [alias.name for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names]
        names += [node.module or "" for node in ast.walk(tree)
                  if isinstance(node, ast.ImportFrom)]
        assert not [n for n in names if n.startswith(("drivers", "hal.sim", "picamera2"))]
        assert "VideoCapture" not in (root / module).read_text()
