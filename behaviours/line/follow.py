"""Follow the painted line: camera frame -> line error -> PID and speed bands -> wheel command.

Seed 000 section 6. The loop runs at ``line_follow.fps`` (13 = the seed's 77 ms) on absolute
deadlines of the event loop's clock, so the period does not drift with the work done in it; a
tick that ends after its next deadline counts as an overrun. The PID steers in every band; the
band of the error (< 30 px straight on, 30-80 gentle, 80-150 strong, > 150 full turn) sets the
forward speed, down to a turn on the spot. A lost line turns the robot toward where the line
was last seen; after ``line_follow.lost_frames`` lost frames in a row the robot stops and
``run()`` raises LineLostError.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections import deque
from dataclasses import replace
from typing import Any

import structlog

from behaviours.line.colours import parse_colour
from behaviours.line.config import FollowConfig
from behaviours.line.tracker import LineReading, LineTracker
from hal.devices import Camera, DeviceUnavailable, LinkDown, Motors
from hal.looptime.deadline import DeadlineSleeper
from hal.readings import Frame, MotorCommand
from hal.settings import SettingsView
from hal.telemetry import NULL_TELEMETRY, Telemetry

log = structlog.get_logger(__name__)

_HISTORY = 512  # ticks kept for the fps, jitter and latency figures
# The live view's line sample (and its chance of a camera image) at most this often: every
# call costs even when the viewer drops it (~17 us inside a running simulation, the caches
# full of the world), and the camera gives 13 frames a second.
_SHOW_PERIOD_S = 0.1


class LineLostError(RuntimeError):
    """The line stayed out of sight too long; the robot has been stopped."""


class LineFollower:
    """The line-following control loop; a state starts ``run()`` as a task and cancels it.

    Args:
        camera: the frame source (started by the supervisor).
        motors: the drive wheels; ``drive`` may raise LinkDown, the loop carries on.
        settings: the running config; ``line_follow.*`` is read live through ``watch``.
        tracker: the vision step (a fresh LineTracker by default).
        telemetry: the live view gets each frame with the tracked line (decimated there).
    """

    def __init__(self, camera: Camera, motors: Motors, settings: SettingsView, *,
                 tracker: LineTracker | None = None, name: str = "line_follow",
                 telemetry: Telemetry = NULL_TELEMETRY) -> None:
        self.name = name
        self.telemetry = telemetry
        self._camera = camera
        self._motors = motors
        self._settings = settings
        self._cfg = FollowConfig.from_settings(settings)
        self._server_colour: str | None = None
        self.tracker = tracker or LineTracker(self._cfg.tracker, self._cfg.colour)
        self._state = "idle"
        self._reading: LineReading | None = None
        self._band = ""
        self._command = MotorCommand.stopped()
        self._integral = 0.0
        self._prev_error: float | None = None
        self._prev_t: float | None = None
        self._show_at_s = -math.inf
        self._direction = 1.0  # +1: the line was last seen on the right
        self._last_seq = -1
        self._link_up = True
        self.frames = 0
        self.overruns = 0
        self.lost_count = 0
        self.lost_total = 0
        self.frame_timeouts = 0
        self.bad_frames = 0
        self.link_down_count = 0
        self._ticks: deque[float] = deque(maxlen=_HISTORY)
        self._late_s: deque[float] = deque(maxlen=_HISTORY)
        self._latency_s: deque[float] = deque(maxlen=_HISTORY)

    # --- public -------------------------------------------------------------------------------
    @property
    def period_s(self) -> float:
        return 1.0 / self._cfg.fps

    def set_follow_colour(self, name: str | None) -> bool:
        """Apply the fleet server's FollowColor (None: the configured default).

        An unknown colour is logged and ignored (the robot keeps the colour it has); returns
        whether the colour was accepted.
        """
        try:
            colour = None if name is None else parse_colour(name)
        except ValueError as exc:
            log.warning("line_follow.colour_unknown", colour=name, error=str(exc))
            return False
        self._server_colour = colour
        wanted = colour or self._cfg.colour
        if wanted != self.tracker.colour:
            log.info("line_follow.colour", old=self.tracker.colour, new=wanted)
            self.tracker.set_colour(wanted)
        return True

    async def run(self) -> None:
        """Follow the line until cancelled; LineLostError (wheels stopped) when it is gone."""
        loop = asyncio.get_running_loop()
        unwatch = self._settings.watch("line_follow", self._on_setting)
        self._begin()
        sleeper = DeadlineSleeper(loop)
        next_tick = loop.time()
        log.info("line_follow.start", fps=self._cfg.fps, colour=self.tracker.colour,
                 precise_ticks=sleeper.precise, tracker_kernel=self.tracker.kernel)
        try:
            while True:
                now = loop.time()
                self._ticks.append(now)
                self._late_s.append(max(0.0, now - next_tick))
                frame = await self._fresh_frame(now + 0.9 * self.period_s)
                command = self._step(frame)
                if frame is not None:
                    self._latency_s.append(loop.time() - frame.t_s)
                await self._send(command)
                next_tick += self.period_s
                now = loop.time()
                if now >= next_tick:
                    self.overruns += 1
                    log.warning("line_follow.overrun", late_ms=round((now - next_tick) * 1e3, 1),
                                overruns=self.overruns)
                    behind = now - next_tick
                    next_tick += math.floor(behind / self.period_s) * self.period_s
                    continue
                await sleeper.sleep_until(next_tick)
        except LineLostError:
            self._state = "lost"
            raise
        finally:
            unwatch()
            sleeper.close()
            await self._stop_wheels()
            if self._state != "lost":
                self._state = "stopped"
            log.info("line_follow.stop", state=self._state, frames=self.frames,
                     overruns=self.overruns, lost_total=self.lost_total)

    def decide(self, reading: LineReading, width_px: int, dt_s: float) -> MotorCommand:
        """One control step: PID on the error, the band's speed; raises LineLostError."""
        cfg = self._cfg
        if reading.lost:
            return self._recover(reading)
        if self.lost_count:
            log.info("line_follow.found", after_frames=self.lost_count)
            self._prev_error = None
        self.lost_count = 0
        self._state = "following"
        error_px = reading.error_px
        if abs(error_px) >= 2:
            self._direction = 1.0 if error_px > 0 else -1.0
        error = error_px / max(1.0, width_px / 2)
        derivative = 0.0 if self._prev_error is None or dt_s <= 0 else (
            (error - self._prev_error) / dt_s)
        self._prev_error = error
        forward_px, gentle_px, strong_px = cfg.bands_px
        # The bands are pixels of a camera.width-wide frame; a camera that delivers another
        # size (a UVC camera that ignores the size asked for) gets them scaled.
        size = abs(error_px) * cfg.bands_width_px / max(1, width_px)
        if size > strong_px:
            self._band = "full_turn"
            self._integral = 0.0
            turn = cfg.turn_speed * self._direction
            return MotorCommand.from_signed(turn, -turn)
        if size < forward_px:
            self._band, base = "forward", cfg.speed
        elif size < gentle_px:
            self._band, base = "gentle", cfg.speed * cfg.gentle_speed
        else:
            self._band, base = "strong", cfg.speed * cfg.strong_speed
        steer = cfg.kp * error + cfg.kd * derivative + self._integrate(error, dt_s)
        return MotorCommand.from_signed(_clip(base + steer), _clip(base - steer))

    def status(self) -> dict[str, Any]:
        reading = self._reading
        return {
            "state": self._state,
            "colour": self.tracker.colour,
            "error_px": None if reading is None or reading.lost else round(reading.error_px, 1),
            "confidence": 0.0 if reading is None else round(reading.confidence, 2),
            "band": self._band,
            "fps": round(self.measured_fps(), 2),
            "fps_target": self._cfg.fps,
            "frames": self.frames,
            "overruns": self.overruns,
            "lost_count": self.lost_count,
            "lost_total": self.lost_total,
            "frame_timeouts": self.frame_timeouts,
            "bad_frames": self.bad_frames,
            "link_down": self.link_down_count,
            "late_p99_ms": round(_p99(self._late_s) * 1e3, 2),
            "latency_p99_ms": round(_p99(self._latency_s) * 1e3, 2),
            "command": list(self._command.signed()),
        }

    def measured_fps(self) -> float:
        if len(self._ticks) < 2:
            return 0.0
        return (len(self._ticks) - 1) / (self._ticks[-1] - self._ticks[0])

    def recent_ticks(self) -> list[float]:
        """Loop-clock times the recent ticks started at (for jitter figures)."""
        return list(self._ticks)

    def recent_latencies_s(self) -> list[float]:
        """Frame capture to wheel command, for the recent ticks."""
        return list(self._latency_s)

    # --- internals ----------------------------------------------------------------------------
    def _begin(self) -> None:
        self.tracker.reset()
        self._integral = 0.0
        self._prev_error = None
        self._prev_t = None
        self.lost_count = 0
        self._state = "following"

    def _integrate(self, error: float, dt_s: float) -> float:
        cfg = self._cfg
        if cfg.ki <= 0:
            self._integral = 0.0
            return 0.0
        limit = cfg.max_integral / cfg.ki
        self._integral = min(limit, max(-limit, self._integral + error * dt_s))
        return cfg.ki * self._integral

    def _recover(self, reading: LineReading) -> MotorCommand:
        cfg = self._cfg
        self.lost_count += 1
        self.lost_total += 1
        self._integral = 0.0
        self._band = "recovery"
        if self.lost_count == 1:
            log.warning("line_follow.lost", reason=reading.reason, colour=reading.colour,
                        direction="right" if self._direction > 0 else "left")
        if self.lost_count > cfg.lost_frames:
            log.error("line_follow.gave_up", lost_frames=self.lost_count, colour=reading.colour)
            msg = (f"line ({reading.colour}) not seen for {self.lost_count} frames "
                   f"({reading.reason or 'no line'}); robot stopped")
            raise LineLostError(msg)
        self._state = "recovering"
        turn = cfg.turn_speed * self._direction
        return MotorCommand.from_signed(turn, -turn)

    def _step(self, frame: Frame | None) -> MotorCommand:
        if frame is None:
            reading = LineReading(0.0, 0.0, True, colour=self.tracker.colour, reason="no frame")
            width = self._camera.width_px
            dt_s = self.period_s
        else:
            self.frames += 1
            self._last_seq = frame.seq
            width = self._camera.width_px
            try:
                reading = self.tracker.track(frame)  # reads its scan rows only
                width = frame.shape[1]
            except ValueError as exc:  # a frame the tracker cannot read counts as lost
                self.bad_frames += 1
                if self.bad_frames == 1 or self.bad_frames % 100 == 0:
                    log.warning("line_follow.bad_frame", error=str(exc),
                                bad_frames=self.bad_frames)
                reading = LineReading(0.0, 0.0, True, colour=self.tracker.colour,
                                      reason="bad frame")
            dt_s = self.period_s if self._prev_t is None else frame.t_s - self._prev_t
            self._prev_t = frame.t_s
            if frame.t_s >= self._show_at_s and self.telemetry.enabled:
                self._show_at_s = frame.t_s + _SHOW_PERIOD_S
                self._show(frame, reading)
        self._reading = reading
        try:
            self._command = self.decide(reading, width, dt_s)
        except LineLostError:
            self._command = MotorCommand.stopped()
            raise
        return self._command

    def _show(self, frame: Frame, reading: LineReading) -> None:
        marks = [] if reading.x_px is None else [(int(reading.x_px), int(reading.row_px))]
        # The whole image is drawn only when the live view takes one (a few a second).
        self.telemetry.image("camera", lambda: frame.image, marks=marks)
        self.telemetry.sample("line", error_px=round(reading.error_px, 1), lost=reading.lost,
                              confidence=round(reading.confidence, 3), colour=reading.colour)

    async def _fresh_frame(self, deadline: float) -> Frame | None:
        frame = self._camera.latest()
        if frame is not None and frame.seq != self._last_seq:
            return frame
        timeout = max(0.0, deadline - asyncio.get_running_loop().time())
        try:
            return await asyncio.wait_for(self._camera.next_reading(), timeout)
        except TimeoutError:
            self.frame_timeouts += 1
            if self.frame_timeouts == 1 or self.frame_timeouts % 100 == 0:
                log.warning("line_follow.frame_timeout", timeouts=self.frame_timeouts)
        except DeviceUnavailable as exc:
            self.frame_timeouts += 1
            log.warning("line_follow.camera_unavailable", error=str(exc))
            await asyncio.sleep(timeout)
        return None

    async def _send(self, command: MotorCommand) -> None:
        try:
            await self._motors.drive(command)
        except LinkDown:
            self.link_down_count += 1
            self._integral = 0.0
            if self._link_up:
                log.warning("line_follow.link_down")
            self._link_up = False
            return
        if not self._link_up:
            log.info("line_follow.link_up", missed=self.link_down_count)
            self._link_up = True

    async def _stop_wheels(self) -> None:
        with contextlib.suppress(LinkDown):
            await self._motors.stop()

    def _on_setting(self, key: str, value: Any) -> None:
        old = self._cfg
        self._cfg = FollowConfig.from_settings(self._settings)
        if self._cfg.tracker != old.tracker:
            self.tracker.set_params(replace(self._cfg.tracker,
                                            handover_frames=self.tracker.params.handover_frames))
        if self._server_colour is None and self._cfg.colour != self.tracker.colour:
            self.tracker.set_colour(self._cfg.colour)
        log.info("line_follow.tuned", key=key, value=value)


def _clip(duty: float) -> float:
    return min(1.0, max(-1.0, duty))


def _p99(values: deque[float]) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, math.ceil(0.99 * len(ordered)) - 1)]
