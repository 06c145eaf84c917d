"""The line-following control loop: bands, PID, lost line, link loss, timing, live tuning."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

import numpy as np
import pytest
from follow_doubles import (
    HEIGHT,
    LOST,
    WIDTH,
    make,
    run_for,
    seen,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.line.follow import LineLostError
from sim import vclock


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
