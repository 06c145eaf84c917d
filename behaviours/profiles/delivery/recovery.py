"""The seed's error table as RelayBot handles it, and the ``error_recovery`` state's task.

Categories (``delivery.error`` events, ``last_error`` in the state store):

| category | detected by | handled |
|---|---|---|
| ``localisation_divergence`` | ``go_to`` → ``diverged`` (MCL spread) | error_recovery |
| ``no_path`` | ``go_to`` → ``no_path`` (the planner's) | error_recovery |
| ``stuck`` | ``go_to`` → ``no_progress`` (``planner.no_progress_s``) | error_recovery |
| ``lidar_lost`` | localisation ``lidar_lost`` | stopped, waited for up to 30 s, then recovery |
| ``camera_failure`` | no QR reader / frames | warning; verifying times out to waiting |
| ``serial_timeout`` / ``motor`` | the motor link down when a goal fails | error_recovery |
| ``database`` | ``OrderVerifier`` (3 retries) | the order refused, the customer told |
| ``servo`` | ``BoxController`` (3 tries of 2 s) | logged, the delivery goes on |
| ``loading_timeout`` / ``delivering_timeout`` | the state timers | error_recovery |

``error_recovery`` (seed, "Error Recovery State Behavior"): the table's entry stops the wheels
(1); the outputs close the box (2) and play ``failureScan`` (3); the task records the category
(4), drops the order (a parcel still in the box is reported for the operator), and drives home
(5): ``recovery_complete`` → waiting (6), or after 3 failed attempts ``recovery_failed`` → the
root ``estop`` (7, manual intervention). While the LiDAR is lost an attempt first waits for it
(up to ``LIDAR_WAIT_S``), as the navigation states do.
"""

from __future__ import annotations

import asyncio

import structlog

from behaviours.context import RobotContext
from behaviours.nav.localisation.filter import LIDAR_LOST
from behaviours.nav.navigator import NavStack
from behaviours.profiles.delivery.memory import DeliveryMemory
from behaviours.profiles.delivery.states import MAX_RECOVERY_ATTEMPTS

log = structlog.get_logger(__name__)

NAV_CATEGORY = {"diverged": "localisation_divergence", "no_path": "no_path",
                "no_progress": "stuck", "lidar_lost": "lidar_lost"}
"""``NavOutcome.reason`` → the error table's category."""
CATEGORIES = ("localisation_divergence", "no_path", "stuck", "lidar_lost", "camera_failure",
              "encoder_failure", "serial_timeout", "database", "servo", "motor",
              "loading_timeout", "delivering_timeout", "restart")
LIDAR_WAIT_S = 30.0
"""The seed: odometry alone for up to 30 s, then ERROR_RECOVERY (here: stopped, waiting)."""
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


def category_of(reason: str, motors_connected: bool) -> str:
    """A failed goal's category: the motor link first (a robot that cannot drive is stuck
    for that reason), then the navigation's own."""
    if not motors_connected:
        return "serial_timeout"
    return NAV_CATEGORY.get(reason, reason)


class ErrorRecovery:
    """The ``error_recovery`` task (see the module's docstring)."""

    def __init__(self, nav: NavStack, memory: DeliveryMemory, home: tuple[float, float],
                 attempts: int = MAX_RECOVERY_ATTEMPTS) -> None:
        self.nav = nav
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
            outcome = await self.nav.go_to(*self.home)
            ctx.emit("delivery.recovery_attempt", attempt=attempt, reason=outcome.reason,
                     remaining_m=round(outcome.remaining_m, 3))
            if outcome.reached:
                self.category = None
                await ctx.trigger("recovery_complete", category=category)
                return
            await asyncio.sleep(RETRY_PAUSE_S)
        ctx.emit("delivery.recovery_failed", category=category, attempts=self.attempts)
        await ctx.trigger("recovery_failed", reason=f"home unreachable after {category}",
                          source="delivery")
