"""The seed's error table as RelayBot handles it, and the ``error_recovery`` state's task.

Categories (``delivery.error`` events, ``last_error`` in the state store):

| category | detected by | handled |
|---|---|---|
| ``localisation_divergence`` | ``go_to`` → ``diverged`` | re-localised (3 tries), recovery |
| ``no_path`` | ``go_to`` → ``no_path``, again after 2 s relaxed | error_recovery |
| ``stuck`` | no progress for ``delivery.stuck_s``, then an alternate path | error_recovery |
| ``lidar_lost`` | ``lidar_lost``: 30 s on odometry alone | error_recovery |
| ``camera_failure`` | no QR reader / frame reads fail | warning, failure sound, to waiting |
| ``encoder`` | ``EncoderWatch``: driven, ticks frozen 0.5 s | LiDAR-only, half speed; goes on |
| ``serial_timeout`` | the motor link down 1.5 s while driving | emergency stop, recovery |
| ``motor`` | no progress, encoders frozen: the wheels do not turn | emergency stop, recovery |
| ``database`` | ``OrderVerifier`` (3 retries) | the order refused, the customer told |
| ``servo`` | ``BoxController`` (3 tries of 2 s) | logged, the delivery goes on |
| ``loading_timeout`` / ``delivering_timeout`` | the state timers | error_recovery |

``error_recovery`` (seed, "Error Recovery State Behavior"): the table's entry stops the wheels
(1); the outputs close the box (2) and play ``failureScan`` (3); the task records the category
(4), drops the order (a parcel still in the box is reported for the operator), and drives home
(5): ``recovery_complete`` → waiting (6), or after 3 failed attempts ``recovery_failed`` → the
root ``estop`` (7, manual intervention). While the LiDAR is lost an attempt first waits for it
(up to ``LIDAR_WAIT_S``); a diverged localisation is re-localised first (``relocalise``: the
filter restarted around the last estimate, widened, while the robot turns on the spot).
"""

from __future__ import annotations

import asyncio
import math

import numpy as np
import numpy.typing as npt
import structlog

from behaviours.context import RobotContext
from behaviours.nav.localisation.filter import DIVERGED, LIDAR_LOST, LOCALISED, ODOMETRY_ONLY
from behaviours.nav.localisation.motion_model import compose, inverse
from behaviours.nav.navigator import NavStack
from behaviours.profiles.delivery.memory import DeliveryMemory
from behaviours.profiles.delivery.states import MAX_RECOVERY_ATTEMPTS, DeliveryTrigger

FloatArray = npt.NDArray[np.float64]

log = structlog.get_logger(__name__)

NAV_CATEGORY = {"diverged": "localisation_divergence", "no_path": "no_path",
                "no_progress": "stuck", "lidar_lost": "lidar_lost"}
"""``NavOutcome.reason`` → the error table's category."""
CATEGORIES = ("localisation_divergence", "no_path", "stuck", "lidar_lost", "camera_failure",
              "encoder", "serial_timeout", "database", "servo", "motor",
              "loading_timeout", "delivering_timeout", "restart")
LIDAR_WAIT_S = 30.0
"""error_recovery waits this long for a lost LiDAR's scans (the driver reconnects) per attempt."""
RELOCALISE_ATTEMPTS = 3
RELOCALISE_SIGMA_M = 0.3
RELOCALISE_SIGMA_DEG = 20.0
RELOCALISE_SETTLE_S = 3.0
LIDAR_POLL_S = 0.5
RETRY_PAUSE_S = 2.0
"""Between home attempts (the seed's "wait 2 seconds, retry" for a failed plan)."""


async def wait_for_lidar(ctx: RobotContext, nav: NavStack, limit_s: float = LIDAR_WAIT_S
                         ) -> bool:
    """Stopped, wait for the LiDAR's scans to come back; False after ``limit_s`` without."""
    loop = asyncio.get_running_loop()
    start = loop.time()
    await nav.drive.stop()
    ctx.emit("delivery.lidar_wait", limit_s=limit_s)
    while nav.localiser.status == LIDAR_LOST:
        if loop.time() - start >= limit_s:
            ctx.emit("delivery.lidar_not_back", waited_s=round(loop.time() - start, 2))
            return False
        await asyncio.sleep(LIDAR_POLL_S)
    ctx.emit("delivery.lidar_back", waited_s=round(loop.time() - start, 2))
    return True


async def face(nav: NavStack, x_m: float, y_m: float, limit_s: float = 10.0) -> None:
    """Turn on the spot towards a map point."""
    from behaviours.motion.config import DriveTuning
    from behaviours.motion.waypoint_drive import wheel_command
    from hal.readings import MotorCommand

    tuning = DriveTuning.from_settings(nav.settings)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + limit_s
    while loop.time() < deadline:
        pose = nav.pose()
        error = math.atan2(y_m - pose.y_m, x_m - pose.x_m) - pose.theta_rad
        error = math.atan2(math.sin(error), math.cos(error))
        if abs(error) < math.radians(5):
            break
        speed = max(tuning.min_mps, min(tuning.turn_mps, abs(error) * 0.25))
        sign = 1 if error > 0 else -1
        await nav.motors.drive(wheel_command(-sign * speed, sign * speed, tuning))
        await asyncio.sleep(0.05)
    await nav.motors.drive(MotorCommand.stopped())


class GoodCorrection:
    """The filter's last trusted ``map <- odom`` correction: kept while the pose is localised
    (or on odometry alone), frozen once it is lost or jumps. A filter that diverges after the
    LiDAR comes back may have jumped first; odometry since the last trusted correction is
    then the better guess to re-localise around."""

    JUMP_M = 0.3
    JUMP_RAD = math.radians(15)

    def __init__(self, nav: NavStack) -> None:
        self.nav = nav
        self.correction: FloatArray | None = None

    def watch(self) -> None:
        self.nav.service.poses.listen(lambda _pose: self.sample())

    def sample(self) -> None:
        loc = self.nav.localiser
        if loc.status not in (LOCALISED, ODOMETRY_ONLY):
            return
        new = np.array(loc.correction, dtype=np.float64)
        old = self.correction
        if old is not None and loc.status == LOCALISED and (
                math.hypot(new[0] - old[0], new[1] - old[1]) > self.JUMP_M
                or abs(math.remainder(new[2] - old[2], math.tau)) > self.JUMP_RAD):
            return  # a jump, not a correction: keep the old one
        self.correction = new

    def pose(self) -> tuple[float, float, float] | None:
        """The map pose by the trusted correction and live odometry, or None."""
        if self.correction is None:
            return None
        p = compose(self.correction, _odom(self.nav))
        return float(p[0]), float(p[1]), float(p[2])


def _odom(nav: NavStack) -> FloatArray:
    p = nav.odometry.pose()
    return np.array([p.x_m, p.y_m, p.theta_rad], dtype=np.float64)


async def relocalise(ctx: RobotContext, nav: NavStack, good: GoodCorrection | None = None,
                     attempts: int = RELOCALISE_ATTEMPTS) -> bool:
    """The seed's "attempt re-localisation, 3 attempts": the filter restarted (around the
    pose by the last trusted correction, then around its own estimate) with a wider spread,
    the robot turning on the spot (a full turn, in quarters) so the scans reach it; True
    once localised."""
    await nav.drive.stop()
    for attempt in range(1, attempts + 1):
        if nav.localiser.status == LIDAR_LOST:
            return False
        trusted = good.pose() if good is not None and attempt < attempts else None
        here = nav.pose()
        x, y, theta = trusted if trusted is not None else (here.x_m, here.y_m, here.theta_rad)
        nav.localiser.start_at(x, y, theta, RELOCALISE_SIGMA_M,
                               math.radians(RELOCALISE_SIGMA_DEG))
        nav.localiser.correction = compose(np.array([x, y, theta]), inverse(
            _odom(nav)))
        pose = nav.pose()
        for quarter in range(1, 5):
            heading = pose.theta_rad + quarter * math.pi / 2
            await face(nav, pose.x_m + math.cos(heading), pose.y_m + math.sin(heading))
        for _ in range(round(RELOCALISE_SETTLE_S / 0.2)):  # a few more scans to settle
            if nav.localiser.status == LOCALISED:
                break
            await asyncio.sleep(0.2)
        ok = nav.localiser.status == LOCALISED
        ctx.emit("delivery.relocalise", attempt=attempt, ok=ok)
        if ok:
            return True
    return False


def category_of(reason: str, motors_connected: bool, encoders_failed: bool = False) -> str:
    """A failed goal's category: the motor link first (a robot that cannot drive is stuck
    for that reason: ``serial_timeout``), then wheels that do not turn (no progress while the
    encoder counts are frozen: neither the ticks nor the LiDAR see motion: ``motor``), then
    the navigation's own."""
    if not motors_connected:
        return "serial_timeout"
    if encoders_failed and reason == "no_progress":
        return "motor"
    return NAV_CATEGORY.get(reason, reason)


class ErrorRecovery:
    """The ``error_recovery`` task (see the module's docstring)."""

    def __init__(self, nav: NavStack, memory: DeliveryMemory, home: tuple[float, float],
                 good: GoodCorrection | None = None, attempts: int = MAX_RECOVERY_ATTEMPTS
                 ) -> None:
        self.nav = nav
        self.good = good
        self.memory = memory
        self.home = home
        self.attempts = attempts
        self.category: str | None = None
        self.recoveries = 0

    async def run(self, ctx: RobotContext) -> None:
        category = self.category or "unknown"
        self.recoveries += 1
        await self.nav.drive.stop()
        await self.memory.error(category)
        parcel = self.memory.parcel_in_box
        order_id = self.memory.order_id
        if order_id is not None:
            await self.memory.abandoned()
            ctx.emit("delivery.order_abandoned", order_id=order_id, parcel_in_box=parcel)
        ctx.emit("delivery.recovery", category=category, attempts=self.attempts)
        log.error("delivery.error_recovery", category=category, order_id=order_id)
        for attempt in range(1, self.attempts + 1):
            if self.nav.localiser.status == LIDAR_LOST:
                await wait_for_lidar(ctx, self.nav)
            if self.nav.localiser.status == DIVERGED:
                await relocalise(ctx, self.nav, self.good)
            outcome = await self.nav.go_to(*self.home)
            ctx.emit("delivery.recovery_attempt", attempt=attempt, reason=outcome.reason,
                     remaining_m=round(outcome.remaining_m, 3))
            if outcome.reached:
                self.category = None
                await ctx.trigger(DeliveryTrigger.RECOVERY_COMPLETE, category=category)
                return
            await asyncio.sleep(RETRY_PAUSE_S)
        ctx.emit("delivery.recovery_failed", category=category, attempts=self.attempts)
        await ctx.trigger(DeliveryTrigger.RECOVERY_FAILED,
                          reason=f"home unreachable after {category}", source="delivery")
