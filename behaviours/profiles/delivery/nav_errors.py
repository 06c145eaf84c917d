"""The seed's error table, its navigation rows, around ``NavStack.go_to``.

- **Obstacle collision**: the front IR sensor under ``delivery.obstacle_cm`` (10 cm) while
  the robot drives: stop at once, back up ``delivery.back_up_m`` (20 cm; less when the LiDAR
  sees something behind it: the check behind), plan again (``delivery.obstacle``).
- **Path planning failure**: no path: log it, wait ``delivery.plan_retry_s`` (2 s), plan once
  more with the relaxed constraint (the planner's clearance down to
  ``delivery.relaxed_clearance_m``; ``delivery.no_path``); failing again, the caller's
  navigation error (error_recovery).
- **Goal unreachable**: ``go_to`` reports no progress after the planner's ``no_progress_s``
  (10 s); that is not yet the seed's "stuck": the goal is planned again from where the robot
  is until it has made no progress for ``delivery.stuck_s`` (30 s, ``delivery.stuck``). Then
  an alternate path: one that keeps out of the spot ahead where it stuck
  (``delivery.alternate_path``); that failing too, the caller's navigation error.

The planner's own settings stay as they are for every other robot: a retry swaps the
follower's planner for one built from this robot's map with the relaxed or blocked
constraint, and puts the original back afterwards.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import itertools
import math
from collections.abc import Iterator

import numpy as np
import structlog

from behaviours.context import RobotContext
from behaviours.motion.config import DriveTuning
from behaviours.motion.waypoint_drive import wheel_command
from behaviours.nav.navigator import NavOutcome, NavStack
from behaviours.nav.planner import Planner
from behaviours.profiles.delivery.config import DeliveryConfig
from hal.devices import LinkDown, RangeSensor
from hal.readings import MotorCommand

log = structlog.get_logger(__name__)

WATCH_S = 0.05
BACK_MPS = 0.1
BACK_MAX_S = 5.0
BEHIND_MARGIN_M = 0.05
ROBOT_RADIUS_M = 0.18
"""The footprint (docs/delivery.md, "Distance < 50 cm")."""
BLOCK_AHEAD_M = 0.75
BLOCK_RADIUS_M = 0.25
"""The alternate path keeps out of a disc this wide, this far ahead of where it stuck (the
disc's edge beyond the planner's clearance from the robot, or its start would be blocked)."""
PROGRESSED_M = 0.2
"""Between two stops this much closer to the goal: progress, the stuck time starts again."""
LINK_DOWN = "link_down"
SERIAL_TIMEOUT_S = 1.5
"""The link's resends (3 x 500 ms) unanswered: the motor board counts as gone."""


class NavErrors:
    """``go`` is ``NavStack.go_to`` with the error table's navigation rows."""

    def __init__(self, nav: NavStack, front_range: RangeSensor | None) -> None:
        self.nav = nav
        self.front_range = front_range
        self._relaxed: tuple[float, Planner] | None = None
        self.encoders_failed = False
        """Set by the encoder watch while the encoder counts are frozen."""

    async def go(self, ctx: RobotContext, x_m: float, y_m: float) -> NavOutcome:
        """Drive to (x, y) as the error table says; a failure is the caller's to report."""
        cfg = DeliveryConfig.from_settings(ctx.settings)
        loop = asyncio.get_running_loop()
        no_progress_s = self.nav.planner_config.no_progress_s
        stuck_since: float | None = None
        stuck_remaining = math.inf
        relaxed_tried = False
        while True:
            if relaxed_tried:  # planned with the relaxed constraint once: it stays relaxed
                with self._planning_with(self._relaxed_planner(self._relaxed_m(cfg))):
                    outcome = await self._drive(ctx, x_m, y_m, cfg)
            else:
                outcome = await self._drive(ctx, x_m, y_m, cfg)
            if outcome is None:
                continue  # backed away from an obstacle: plan again
            if outcome.reason == "no_path" and not relaxed_tried:
                relaxed_tried = True
                outcome = await self._relaxed_retry(ctx, x_m, y_m, cfg, outcome)
                if outcome is None:
                    continue
            if outcome.reason != "no_progress" or not self.nav.motors.connected \
                    or self.encoders_failed:
                # Not the planner's to work round: the motor board's link is down (a serial
                # timeout) or the wheels do not turn (no ticks and no progress: motor
                # failure); error_recovery at once, as the error table says.
                return outcome
            now = loop.time()
            if stuck_since is None or outcome.remaining_m < stuck_remaining - PROGRESSED_M:
                # Got somewhere since (or the first stop): stuck since the planner's limit.
                stuck_since, stuck_remaining = now - no_progress_s, outcome.remaining_m
            stuck_for = now - stuck_since
            if stuck_for < cfg.stuck_s:
                ctx.emit("delivery.stuck", stuck_s=round(stuck_for, 2), limit_s=cfg.stuck_s,
                         action="replan")
                continue
            log.error("delivery.goal_unreachable", stuck_s=round(stuck_for, 2),
                      goal_x_m=x_m, goal_y_m=y_m)
            ctx.emit("delivery.stuck", stuck_s=round(stuck_for, 2), limit_s=cfg.stuck_s,
                     action="alternate_path")
            return await self._alternate(ctx, x_m, y_m, cfg, outcome)

    # -- one drive, watched for an obstacle closer than obstacle_cm -----------------------------
    async def _drive(self, ctx: RobotContext, x_m: float, y_m: float, cfg: DeliveryConfig
                     ) -> NavOutcome | None:
        """``go_to``; None when it was stopped for an obstacle (and the robot backed away)."""
        drive = asyncio.create_task(self.nav.go_to(x_m, y_m))
        loop = asyncio.get_running_loop()
        started = loop.time()
        link_down_at: float | None = None
        try:
            while True:
                done, _ = await asyncio.wait({drive}, timeout=WATCH_S)
                if done:
                    return drive.result()
                now = loop.time()
                if self.nav.motors.connected:
                    link_down_at = None
                elif link_down_at is None:
                    link_down_at = now
                elif now - link_down_at >= SERIAL_TIMEOUT_S:
                    # The serial timeout: the link's 3 resends of 500 ms went unanswered;
                    # the motor commands cannot be carried out: error_recovery.
                    drive.cancel()
                    with contextlib.suppress(asyncio.CancelledError):
                        await drive
                    pose = self.nav.pose()
                    return NavOutcome(
                        LINK_DOWN, (x_m, y_m), pose.x_m, pose.y_m,
                        math.hypot(x_m - pose.x_m, y_m - pose.y_m), 0, now - started,
                        f"motor board silent for {now - link_down_at:.1f} s")
                close_cm = self.front_cm()
                if close_cm is not None and close_cm < cfg.obstacle_cm:
                    drive.cancel()
                    with contextlib.suppress(asyncio.CancelledError):
                        await drive
                    await self.nav.drive.stop()
                    await self._back_away(ctx, close_cm, cfg)
                    return None
        finally:
            if not drive.done():
                drive.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await drive

    def front_cm(self) -> float | None:
        """The front IR sensor's fresh reading (None: none, or older than 1 s)."""
        reading = None if self.front_range is None else self.front_range.latest()
        if reading is None:
            return None
        if asyncio.get_running_loop().time() - reading.t_s > 1.0:
            return None  # the guard deals with a stale sensor
        return reading.distance_cm

    def behind_m(self) -> float:
        """Free distance behind the robot's rim in the newest LiDAR scan (inf: nothing seen
        within its width, or no scan)."""
        scan = self.nav.lidar.latest()
        if scan is None:
            return math.inf
        points = scan.points_xy()
        if points.shape[0] == 0:
            return math.inf
        behind = points[(points[:, 0] < 0) & (np.abs(points[:, 1]) < ROBOT_RADIUS_M + 0.03)]
        if behind.shape[0] == 0:
            return math.inf
        return float(np.min(-behind[:, 0])) - ROBOT_RADIUS_M

    async def _back_away(self, ctx: RobotContext, close_cm: float, cfg: DeliveryConfig) -> None:
        """Stopped for an obstacle: back up (checking behind), then the caller plans again."""
        free_m = self.behind_m()
        want = max(0.0, min(cfg.back_up_m, free_m - BEHIND_MARGIN_M))
        log.error("delivery.obstacle", distance_cm=round(close_cm, 1), back_up_m=round(want, 3))
        backed = await self._reverse(want)
        ctx.emit("delivery.obstacle", distance_cm=round(close_cm, 1),
                 backed_m=round(backed, 3), wanted_m=cfg.back_up_m,
                 behind_m=None if math.isinf(free_m) else round(free_m, 3))

    async def _reverse(self, distance_m: float) -> float:
        """Straight back ``distance_m`` on odometry, stopping if the LiDAR sees something
        close behind; the distance backed."""
        if distance_m <= 0:
            return 0.0
        nav = self.nav
        tuning = DriveTuning.from_settings(nav.settings)
        loop = asyncio.get_running_loop()
        start = nav.odometry.pose()
        deadline = loop.time() + BACK_MAX_S
        backed = 0.0
        try:
            while backed < distance_m and loop.time() < deadline \
                    and self.behind_m() > BEHIND_MARGIN_M:
                with contextlib.suppress(LinkDown):
                    await nav.motors.drive(wheel_command(-BACK_MPS, -BACK_MPS, tuning))
                await asyncio.sleep(WATCH_S)
                pose = nav.odometry.pose()
                backed = math.hypot(pose.x_m - start.x_m, pose.y_m - start.y_m)
        finally:
            with contextlib.suppress(LinkDown):
                await nav.motors.drive(MotorCommand.stopped())
        return backed

    # -- planning failure: wait, relax, once ---------------------------------------------------
    async def _relaxed_retry(self, ctx: RobotContext, x_m: float, y_m: float,
                             cfg: DeliveryConfig, failed: NavOutcome) -> NavOutcome | None:
        clearance = self._relaxed_m(cfg)
        log.error("delivery.no_path", detail=failed.detail, retry_in_s=cfg.plan_retry_s,
                  relaxed_clearance_m=clearance)
        ctx.emit("delivery.no_path", detail=failed.detail, retry_in_s=cfg.plan_retry_s,
                 relaxed_clearance_m=clearance)
        await asyncio.sleep(cfg.plan_retry_s)
        with self._planning_with(self._relaxed_planner(clearance)):
            outcome = await self._drive(ctx, x_m, y_m, cfg)
        ctx.emit("delivery.relaxed_plan", reason="obstacle" if outcome is None
                 else outcome.reason)
        return outcome

    def _relaxed_m(self, cfg: DeliveryConfig) -> float:
        return min(cfg.relaxed_clearance_m, self.nav.planner_config.clearance_m)

    def _relaxed_planner(self, clearance_m: float) -> Planner:
        if self._relaxed is None or self._relaxed[0] != clearance_m:
            base = self.nav.planner
            config = dataclasses.replace(base.config, clearance_m=clearance_m)
            self._relaxed = (clearance_m, Planner(base.grid, config, kernel=base.kernel,
                                                  keepout=base.keepout))
        return self._relaxed[1]

    @contextlib.contextmanager
    def _planning_with(self, planner: Planner) -> Iterator[None]:
        follower = self.nav.follower
        before = follower.planner
        follower.planner = planner
        try:
            yield
        finally:
            follower.planner = before

    # -- goal unreachable: an alternate path, once ---------------------------------------------
    async def _alternate(self, ctx: RobotContext, x_m: float, y_m: float, cfg: DeliveryConfig,
                         stuck: NavOutcome) -> NavOutcome:
        block = self._spot_ahead()
        blocked = self.nav.planner.with_obstacles(_disc(block, BLOCK_RADIUS_M))
        ctx.emit("delivery.alternate_path", block_x_m=round(block[0], 3),
                 block_y_m=round(block[1], 3), block_radius_m=BLOCK_RADIUS_M)
        with self._planning_with(blocked):
            outcome = await self._drive(ctx, x_m, y_m, cfg)
        if outcome is None:
            outcome = dataclasses.replace(stuck, detail="alternate path: stopped for an "
                                                        "obstacle")
        ctx.emit("delivery.alternate_result", reason=outcome.reason,
                 remaining_m=round(outcome.remaining_m, 3))
        if not outcome.reached and outcome.reason == "no_path":
            # No way round the spot: the goal is still unreachable (the category is stuck).
            outcome = dataclasses.replace(outcome, reason="no_progress",
                                          detail=f"stuck, and no alternate path: "
                                                 f"{outcome.detail}")
        return outcome

    def _spot_ahead(self) -> tuple[float, float]:
        """Where the robot was headed when it stuck: along its remaining path, else ahead."""
        path = self.nav.follower.remaining_path()
        pose = self.nav.pose()
        if len(path) >= 2:
            walked = 0.0
            for (ax, ay), (bx, by) in itertools.pairwise(path):
                leg = math.hypot(bx - ax, by - ay)
                if walked + leg >= BLOCK_AHEAD_M and leg > 0:
                    f = (BLOCK_AHEAD_M - walked) / leg
                    return ax + (bx - ax) * f, ay + (by - ay) * f
                walked += leg
            return path[-1]
        return (pose.x_m + BLOCK_AHEAD_M * math.cos(pose.theta_rad),
                pose.y_m + BLOCK_AHEAD_M * math.sin(pose.theta_rad))


def _disc(centre: tuple[float, float], radius_m: float, step_m: float = 0.05
          ) -> list[tuple[float, float]]:
    """Points filling a disc (obstacles for the planner)."""
    cx, cy = centre
    n = int(radius_m / step_m)
    return [(cx + i * step_m, cy + j * step_m) for i in range(-n, n + 1)
            for j in range(-n, n + 1) if math.hypot(i, j) * step_m <= radius_m]
