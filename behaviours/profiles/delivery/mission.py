"""RelayBot's state tasks: what the robot does in each of the seed's nine states.

Each task runs while its state is active (started on entry, cancelled on exit) and ends by
firing one of the table's triggers. The navigation is ``NavStack.go_to`` (the map, MCL pose and
replanning of issue 16); people come from its LiDAR people tracker (``people_out``).

- ``waiting``: back home first when more than ``position_tolerance_m`` away (property 1, also
  after a refused order), then the first person inside ``zone_radius_m`` of home is a customer
  (``person_detected``; property 2). After a restart with an order in hand it resumes instead.
- ``approaching``: drives to a standoff ``approach_distance_m`` in front of the customer,
  re-aimed while they move; closer than that (< 50 cm, property 4) → ``reached_customer``; the
  customer gone for ``LOST_S`` or out of the zone → stop, ``person_lost`` (property 3).
- ``verifying``: QR codes from the forward camera until one is valid (``order_valid``, the
  order and the customer's position kept, property 11) or refused (``order_invalid``); the
  table's 30 s timeout ends it otherwise.
- ``navigating_to_warehouse`` / ``returning_to_customer`` / ``resetting``: one goal each.
- ``loading``: waits for ``delivery.confirm_loaded`` (the table's 60 s timeout otherwise).
- ``delivering``: the box open exactly ``delivery_duration_s``, then ``delivery_complete``.
- ``error_recovery``: ``behaviours.profiles.delivery.recovery``.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

import structlog

from behaviours.context import RobotContext
from behaviours.machine_tables import CoreTrigger
from behaviours.nav.localisation.filter import LIDAR_LOST, LOCALISED
from behaviours.nav.localisation.people import Person
from behaviours.nav.navigator import NavOutcome, NavStack
from behaviours.profiles.delivery.memory import DeliveryMemory
from behaviours.profiles.delivery.nav_errors import NavErrors
from behaviours.profiles.delivery.orders import Accepted, OrderVerifier
from behaviours.profiles.delivery.recovery import GoodCorrection, category_of, face, relocalise
from behaviours.profiles.delivery.states import DeliveryTrigger
from hal.devices import LinkDown
from hal.tasks import cancel_and_wait

log = structlog.get_logger(__name__)

WATCH_S = 0.1
"""How often the tasks look at the people tracker and the localisation."""
LOST_S = 2.0
"""A customer not seen this long while approached has gone (property 3)."""
RETARGET_M = 0.3
"""A customer who moved this far from where the standoff was aimed: aim again."""
DISMISS_M = 0.8
"""Someone standing this close to a customer just served or refused is that customer."""
DISMISS_CLEAR_S = 3.0
"""... until nobody has stood there for this long."""
QR_POLL_S = 1.0
APPROACH_ATTEMPTS = 6
"""Standoffs tried (``no_path``/``no_progress``: a moving customer, a spot by a shelf) before
the approach is a navigation error."""
STANDOFF_TURNS_RAD = (0.0, math.radians(35), math.radians(-35), math.radians(70),
                      math.radians(-70), 0.0)
BODIES_M = 0.38
"""Centre to centre less this is the gap between robot and customer: the robot's footprint
radius (0.18 m) and a customer's (0.2 m). "< 50 cm" (property 4) is that gap: the front range
sensor's obstacle guard stops the robot 30 cm before anything, so centres never get 50 cm
apart."""
STANDOFF_GAP_M = 0.34
"""The gap the approach aims for: inside the 50 cm, outside the guard's 30 cm."""
GAP_MARGIN_M = 0.1
APPROACH_PROGRESS_M = 0.1
"""Getting this much closer to the customer is progress (the approach's stuck clock)."""
HAND_CLEAR_S = 0.5
"""A hand gone from the box opening this long: the box may close."""
HAND_MARGIN_S = 0.05
"""Reached below 50 cm less this: the LiDAR sees the near side of the legs, the pose is a few
centimetres off; the true gap must still be under 50 cm."""


@dataclass(frozen=True, slots=True)
class Places:
    """Where things are on the map (the ``delivery`` section)."""

    home: tuple[float, float]
    warehouse: tuple[float, float]
    zone_radius_m: float
    tolerance_m: float
    approach_m: float
    delivery_s: float
    verifying_s: float
    loading_s: float
    delivering_limit_s: float = 15.0


class DeliveryMission:
    """The state tasks over one robot's navigation stack, orders and memory."""

    def __init__(self, nav: NavStack, verifier: OrderVerifier, memory: DeliveryMemory,
                 places: Places, mark_delivered: Callable[[int], Awaitable[None]],
                 errors: NavErrors | None = None) -> None:
        self.nav = nav
        self.errors = errors if errors is not None else NavErrors(nav, None)
        self.verifier = verifier
        self.memory = memory
        self.places = places
        self.mark_delivered = mark_delivered
        self.good = GoodCorrection(nav)
        self.customer: Person | None = None
        self.dismissed: list[tuple[float, float, float]] = []  # (x, y, last seen there)
        self.last_category: str | None = None
        self.may_resume = True
        """Only the first ``waiting`` after boot resumes an order the store holds."""

    # -- helpers -------------------------------------------------------------------------------
    def people(self) -> list[Person]:
        return list(self.nav.service.people_out.latest() or [])

    def distance_home_m(self) -> float:
        pose = self.nav.pose()
        return math.hypot(pose.x_m - self.places.home[0], pose.y_m - self.places.home[1])

    async def go(self, ctx: RobotContext, x_m: float, y_m: float, why: str) -> NavOutcome:
        """``go_to`` with the error table's navigation rows (``nav_errors``: obstacle, failed
        plan, goal unreachable) and its localisation rule: a diverged filter is stopped and
        re-localised (3 attempts) and the goal tried again; any other failure is returned (a
        lost LiDAR has had its 30 s of odometry inside the localisation already)."""
        while True:
            ctx.emit("delivery.goal", why=why, goal_x_m=round(x_m, 3), goal_y_m=round(y_m, 3))
            pose = self.nav.pose()
            off_m = math.hypot(x_m - pose.x_m, y_m - pose.y_m)
            if off_m <= self.nav.planner_config.goal_tolerance_m:  # there already (a resume)
                return NavOutcome("reached", (x_m, y_m), pose.x_m, pose.y_m, off_m, 0, 0.0)
            outcome = await self.errors.go(ctx, x_m, y_m)
            if outcome.reason != "diverged" or not await relocalise(ctx, self.nav, self.good):
                return outcome

    async def nav_failed(self, ctx: RobotContext, outcome: NavOutcome) -> None:
        category = category_of(outcome.reason, self.nav.motors.connected,
                               self.errors.encoders_failed)
        self.last_category = category
        if category in ("motor", "serial_timeout"):
            # The error table: a motor command that fails is an emergency stop and a
            # critical error before error_recovery.
            log.critical("delivery.motor_failure", category=category, detail=outcome.detail)
            with contextlib.suppress(LinkDown):
                await self.nav.motors.stop()
        ctx.emit("delivery.error", category=category, detail=outcome.detail,
                 state=ctx.state)
        await ctx.trigger(DeliveryTrigger.NAVIGATION_ERROR, category=category)

    def _dismiss(self, x_m: float, y_m: float) -> None:
        now = asyncio.get_running_loop().time()
        self.dismissed.append((x_m, y_m, now))

    def _is_dismissed(self, person: Person, now: float) -> bool:
        kept = []
        hit = False
        for x, y, seen_s in self.dismissed:
            last_s = seen_s
            if math.hypot(person.map_x_m - x, person.map_y_m - y) <= DISMISS_M:
                hit = True
                last_s = now
            if now - last_s < DISMISS_CLEAR_S:
                kept.append((x, y, last_s))
        self.dismissed = kept
        return hit

    def _in_zone(self, person: Person, margin_m: float = 0.0) -> bool:
        hx, hy = self.places.home
        return math.hypot(person.map_x_m - hx, person.map_y_m - hy) \
            <= self.places.zone_radius_m + margin_m

    # -- the states ----------------------------------------------------------------------------
    async def waiting(self, ctx: RobotContext) -> None:
        memory = self.memory
        resume, self.may_resume = self.may_resume, False
        if resume and memory.parcel_in_box and memory.order_id is not None \
                and memory.customer_position() is not None:
            ctx.emit("delivery.resumed", order_id=memory.order_id, parcel_in_box=True)
            await ctx.trigger(DeliveryTrigger.RESUME_DELIVERY, order_id=memory.order_id)
            return
        if resume and memory.order_id is not None and memory.customer_position() is not None:
            ctx.emit("delivery.resumed", order_id=memory.order_id, parcel_in_box=False)
            await ctx.trigger(DeliveryTrigger.RESUME_ORDER, order_id=memory.order_id)
            return
        if self.distance_home_m() > self.places.tolerance_m:
            outcome = await self.go(ctx, *self.places.home, why="home")
            if not outcome.reached:
                category = category_of(outcome.reason, self.nav.motors.connected,
                                       self.errors.encoders_failed)
                self.last_category = category
                ctx.emit("delivery.error", category=category, detail=outcome.detail,
                         state=ctx.state)
                await ctx.trigger(DeliveryTrigger.ERROR, category=category)
                return
            ctx.emit("delivery.at_home", error_m=round(outcome.remaining_m, 4))
        loop = asyncio.get_running_loop()
        while True:
            now = loop.time()
            if self.nav.localiser.status == LOCALISED:
                for person in sorted(self.people(), key=lambda p: p.range_m):
                    if self._in_zone(person) and not self._is_dismissed(person, now):
                        self.customer = person
                        ctx.emit("delivery.person_detected", track_id=person.track_id,
                                 map_x_m=round(float(person.map_x_m), 3),
                                 map_y_m=round(float(person.map_y_m), 3),
                                 rel_x_m=round(float(person.x_m), 3),
                                 rel_y_m=round(float(person.y_m), 3))
                        await ctx.trigger(DeliveryTrigger.PERSON_DETECTED, track_id=person.track_id)
                        return
            await asyncio.sleep(WATCH_S)

    def _track(self, target: Person) -> Person | None:
        """The customer in the newest scan: same track, else the nearest within the gate."""
        people = self.people()
        for p in people:
            if p.track_id == target.track_id:
                return p
        near = [p for p in people if math.hypot(p.map_x_m - target.map_x_m,
                                                p.map_y_m - target.map_y_m) <= 0.5]
        return min(near, key=lambda p: math.hypot(p.map_x_m - target.map_x_m,
                                                   p.map_y_m - target.map_y_m), default=None)

    def _standoff(self, person: Person, turn_rad: float = 0.0) -> tuple[float, float]:
        """In front of the customer (``STANDOFF_GAP_M`` between the bodies), on the line from
        the customer to the robot, turned by ``turn_rad`` around the customer (another side
        when that spot cannot be reached)."""
        pose = self.nav.pose()
        bearing = math.atan2(pose.y_m - person.map_y_m, pose.x_m - person.map_x_m) + turn_rad
        a = BODIES_M + min(STANDOFF_GAP_M, self.places.approach_m * 0.7)
        return person.map_x_m + math.cos(bearing) * a, person.map_y_m + math.sin(bearing) * a

    async def approaching(self, ctx: RobotContext) -> None:
        target = self.customer
        if target is None:
            await ctx.trigger(DeliveryTrigger.PERSON_LOST, why="no customer")
            return
        loop = asyncio.get_running_loop()
        seen_s = loop.time()
        aimed = (target.map_x_m, target.map_y_m)
        drive: asyncio.Task[NavOutcome] | None = None
        failed = 0
        stuck_s = float(ctx.settings.get("delivery.stuck_s"))
        closest_m, closer_at = math.inf, loop.time()
        try:
            while True:
                now = loop.time()
                found = self._track(target)
                if found is not None:
                    target, seen_s = found, now
                    self.customer = found
                gone = now - seen_s > LOST_S
                if gone or not self._in_zone(target, margin_m=0.5):
                    await cancel_and_wait(drive)
                    await self.nav.drive.stop()
                    ctx.emit("delivery.person_lost", track_id=target.track_id,
                             why="not seen" if gone else "left the zone")
                    self._dismiss(target.map_x_m, target.map_y_m)
                    await ctx.trigger(DeliveryTrigger.PERSON_LOST)
                    return
                pose = self.nav.pose()
                range_m = math.hypot(target.map_x_m - pose.x_m, target.map_y_m - pose.y_m)
                if range_m < closest_m - APPROACH_PROGRESS_M:
                    closest_m, closer_at = range_m, now
                elif now - closer_at > stuck_s:
                    # Goal unreachable: no closer for the error table's 30 s, whatever
                    # standoff (the alternate paths) was tried.
                    await cancel_and_wait(drive)
                    await self.nav.drive.stop()
                    ctx.emit("delivery.stuck", stuck_s=round(now - closer_at, 2),
                             limit_s=stuck_s, action="give_up_approach")
                    await self.nav_failed(ctx, NavOutcome(
                        "no_progress", (target.map_x_m, target.map_y_m), pose.x_m, pose.y_m,
                        range_m, 0, now - closer_at,
                        f"no closer to the customer for {now - closer_at:.1f} s"))
                    return
                if range_m - BODIES_M < self.places.approach_m - GAP_MARGIN_M \
                        and (drive is None or drive.done()):
                    await cancel_and_wait(drive)
                    await self.nav.drive.stop()
                    await self.face(target.map_x_m, target.map_y_m)
                    ctx.emit("delivery.reached_customer", range_m=round(float(range_m), 3),
                             gap_m=round(float(range_m) - BODIES_M, 3),
                             map_x_m=round(float(target.map_x_m), 3),
                             map_y_m=round(float(target.map_y_m), 3))
                    await ctx.trigger(DeliveryTrigger.REACHED_CUSTOMER)
                    return
                moved = math.hypot(target.map_x_m - aimed[0], target.map_y_m - aimed[1])
                if drive is None or moved > RETARGET_M:
                    await cancel_and_wait(drive)
                    aimed = (target.map_x_m, target.map_y_m)
                    turn = STANDOFF_TURNS_RAD[failed % len(STANDOFF_TURNS_RAD)]
                    drive = asyncio.create_task(self.nav.go_to(*self._standoff(target, turn)))
                elif drive.done():
                    outcome = drive.result()
                    if not outcome.reached:
                        failed += 1
                        if outcome.reason in ("diverged", "lidar_lost") \
                                or failed >= APPROACH_ATTEMPTS:
                            await self.nav_failed(ctx, outcome)
                            return
                    drive = None  # the standoff (reached or not) did not do: aim again
                await asyncio.sleep(WATCH_S)
        finally:
            await cancel_and_wait(drive)

    async def face(self, x_m: float, y_m: float) -> None:
        """Turn on the spot towards a map point (the QR camera looks ahead)."""
        await face(self.nav, x_m, y_m)

    async def verifying(self, ctx: RobotContext) -> None:
        qr = ctx.devices.qr
        loop = asyncio.get_running_loop()
        end = loop.time() + self.places.verifying_s
        while loop.time() < end:
            code = None if qr is None else \
                await qr.next_code(min(QR_POLL_S, max(0.01, end - loop.time())))
            if code is None and (qr is None or getattr(qr, "camera_failing", False)):
                await self._camera_failed(ctx, "no QR camera" if qr is None
                                          else str(getattr(qr, "last_error", "")))
                return
            if code is None:
                continue
            verdict = await self.verifier.verify(code)
            customer = self.customer
            if isinstance(verdict, Accepted):
                pose = self.nav.pose()
                cx, cy = (customer.map_x_m, customer.map_y_m) if customer is not None \
                    else (pose.x_m, pose.y_m)
                await self.memory.verified(verdict.order_id, cx, cy)
                await self.memory.persisted.update(stand_x_m=round(pose.x_m, 4),
                                                   stand_y_m=round(pose.y_m, 4))
                ctx.emit("delivery.order_valid", order_id=verdict.order_id,
                         customer_x_m=round(float(cx), 3), customer_y_m=round(float(cy), 3))
                await ctx.trigger(DeliveryTrigger.ORDER_VALID, order_id=verdict.order_id)
                return
            ctx.emit("delivery.order_invalid", reason=verdict.reason, detail=verdict.detail)
            if customer is not None:
                self._dismiss(customer.map_x_m, customer.map_y_m)
            await ctx.trigger(DeliveryTrigger.ORDER_INVALID, reason=verdict.reason)
            return
        if self.customer is not None:
            self._dismiss(self.customer.map_x_m, self.customer.map_y_m)
        await ctx.trigger(CoreTrigger.TIMEOUT)  # the configured limit; the table's 30 s is the cap

    async def _camera_failed(self, ctx: RobotContext, detail: str) -> None:
        """The error table's camera failure: a warning, the customer hears the failure sound
        (``order_invalid``'s), and the robot goes back to waiting; it keeps operating."""
        log.warning("delivery.camera_failure", detail=detail)
        ctx.emit("delivery.camera_failure", category="camera_failure", detail=detail)
        if self.customer is not None:
            self._dismiss(self.customer.map_x_m, self.customer.map_y_m)
        await ctx.trigger(DeliveryTrigger.ORDER_INVALID, reason="camera_failure")

    async def to_warehouse(self, ctx: RobotContext) -> None:
        outcome = await self.go(ctx, *self.places.warehouse, why="warehouse")
        if outcome.reached:
            ctx.emit("delivery.at_warehouse", error_m=round(outcome.remaining_m, 4))
            await ctx.trigger(DeliveryTrigger.REACHED_WAREHOUSE)
        else:
            await self.nav_failed(ctx, outcome)

    async def loading(self, ctx: RobotContext) -> None:
        await asyncio.sleep(self.places.loading_s)
        self.last_category = "loading_timeout"
        ctx.emit("delivery.error", category="loading_timeout", state=ctx.state)
        await ctx.trigger(CoreTrigger.TIMEOUT)

    async def to_customer(self, ctx: RobotContext) -> None:
        await self.memory.loaded()
        values = self.memory.values()
        stand = (values.get("stand_x_m"), values.get("stand_y_m"))
        customer = self.memory.customer_position()
        if isinstance(stand[0], float | int) and isinstance(stand[1], float | int):
            goal = (float(stand[0]), float(stand[1]))
        elif customer is not None:
            goal = customer
        else:
            goal = self.places.home
        outcome = await self.go(ctx, *goal, why="customer")
        if not outcome.reached:
            await self.nav_failed(ctx, outcome)
            return
        if customer is not None:
            await self.face(*customer)
        ctx.emit("delivery.at_customer", error_m=round(outcome.remaining_m, 4))
        await ctx.trigger(DeliveryTrigger.REACHED_CUSTOMER)

    async def delivering(self, ctx: RobotContext) -> None:
        order_id = self.memory.order_id
        await asyncio.sleep(self.places.delivery_s)
        await self.wait_for_hand(ctx)
        await self.memory.handed_over()
        if order_id is not None:
            try:
                await self.mark_delivered(order_id)
            except Exception as exc:  # the database's trouble must not keep the box open
                log.warning("delivery.mark_failed", order_id=order_id, error=str(exc))
        ctx.emit("delivery.delivered", order_id=order_id)
        if self.customer is not None:
            self._dismiss(self.customer.map_x_m, self.customer.map_y_m)
        await ctx.trigger(DeliveryTrigger.DELIVERY_COMPLETE, order_id=order_id)

    async def wait_for_hand(self, ctx: RobotContext) -> None:
        """The box does not close on a hand: while the front IR sensor sees something in the
        box opening (``delivery.hand_cm``), the hand-over waits, until it has been clear for
        ``HAND_CLEAR_S``, and never past the state's hard limit (its timeout then ends the
        state; ``delivery.hand_in_box`` says whether the hand went)."""
        loop = asyncio.get_running_loop()
        start = loop.time()
        limit_s = self.places.delivering_limit_s - self.places.delivery_s - HAND_MARGIN_S
        hand_cm = float(ctx.settings.get("delivery.hand_cm"))
        clear_since: float | None = None
        seen: float | None = None
        while loop.time() - start < limit_s:
            close_cm = self.errors.front_cm()
            now = loop.time()
            if close_cm is not None and close_cm < hand_cm:
                seen = close_cm if seen is None else min(seen, close_cm)
                clear_since = None
            elif seen is None:
                return  # nothing in the opening: the hand-over ends on time
            else:
                clear_since = now if clear_since is None else clear_since
                if now - clear_since >= HAND_CLEAR_S:
                    break
            await asyncio.sleep(WATCH_S)
        waited = round(loop.time() - start, 3)
        gone = clear_since is not None
        ctx.emit("delivery.hand_in_box", waited_s=waited, closest_cm=seen, gone=gone)
        if not gone:
            log.error("delivery.hand_in_box", waited_s=waited, note="still there at the limit")
            await asyncio.Event().wait()  # the state's hard limit decides (error_recovery)

    async def resetting(self, ctx: RobotContext) -> None:
        outcome = await self.go(ctx, *self.places.home, why="home")
        if outcome.reached:
            ctx.emit("delivery.at_home", error_m=round(outcome.remaining_m, 4))
            await ctx.trigger(DeliveryTrigger.REACHED_HOME)
        else:
            await self.nav_failed(ctx, outcome)

    def is_lidar_lost(self) -> bool:
        return self.nav.localiser.status == LIDAR_LOST
