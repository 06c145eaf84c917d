"""The ``delivery`` profile: RelayBot's mission (seed relaybot-delivery-design.md, issue 17).

The nine states under ``mission`` (``states``), their tasks (``mission``, ``recovery``) on the
navigation stack, the LEDs, box and sounds of every transition (``outputs``, run by one task in
order), the order in hand in the state store (``memory``) and ``robotctl confirm-loaded``
(``loading``).

Choices where the seed is ambiguous (docs/delivery.md has the whole list):

- ``waiting`` means "at home, watching the zone": after a refused order, a verifying timeout or
  a recovery the robot drives home first (property 1), then watches.
- A customer just served or refused is not approached again until nobody has stood at that
  spot for 3 s (otherwise a refused customer who stays would be asked again and again).
- ``error_recovery`` drops the order (it reports a parcel still in the box for the operator);
  only a restart resumes one: the first ``waiting`` after boot, with a verified order in the
  store, fires ``resume_delivery`` (parcel in the box: back to the customer) or
  ``resume_order`` (not loaded yet: to the warehouse). These two arrows are added to the
  seed's diagram, which has no restart.
- The config's state timers can only shorten the seed's (the table's timeouts are the seed's
  values and stay the hard caps; the state tasks apply the configured ones).
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import structlog

from behaviours.context import Fault
from behaviours.machine_tables import CoreTrigger
from behaviours.motion.encoder_watch import CommandedMotors, EncoderWatch, EncoderWatchConfig
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import OdometryTracker
from behaviours.nav.localisation.filter import LOCALISED
from behaviours.nav.navigator import NavLocalisation, NavStack, stored_pose
from behaviours.persistence import MissionRecord
from behaviours.profile import BaseProfile, ControlMethod, SiteFacts, StateTask
from behaviours.profiles.delivery import states
from behaviours.profiles.delivery.box import BoxController
from behaviours.profiles.delivery.config import timers_from
from behaviours.profiles.delivery.loading import LoadingConfirmation
from behaviours.profiles.delivery.memory import DELIVERY_MISSION, DeliveryMemory
from behaviours.profiles.delivery.mission import DeliveryMission, Places
from behaviours.profiles.delivery.nav_errors import NavErrors
from behaviours.profiles.delivery.orders import OrderVerifier, SqliteOrders, sqlite_path
from behaviours.profiles.delivery.outputs import StateOutputs
from behaviours.profiles.delivery.recovery import ErrorRecovery
from behaviours.service import Service, TaskService
from hal.devices import Audio, Encoders, ServoBox

if TYPE_CHECKING:
    from pathlib import Path

    from behaviours.context import RobotContext

log = structlog.get_logger(__name__)

POSE_RECORD = MissionRecord("delivery.pose", 1, {"x_m": None, "y_m": None, "heading_rad": None})
"""The last trusted pose, every second (``localisation.initial_pose = "store"`` restarts there:
a daemon killed on the way back to a customer must know where it is)."""
_STORE_POSE_S = 1.0

RESUME_TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": states.DeliveryTrigger.RESUME_DELIVERY, "source": states.path(states.WAITING),
     "dest": states.path(states.TO_CUSTOMER)},
    {"trigger": states.DeliveryTrigger.RESUME_ORDER, "source": states.path(states.WAITING),
     "dest": states.path(states.TO_WAREHOUSE)},
]
"""After a restart with a verified order in the store (not in the seed's diagram)."""


class _HeardAudio:
    """The speaker, each sound also an event (``delivery.sound``) for the record."""

    def __init__(self, audio: Audio, emit: Callable[..., None]) -> None:
        self.audio = audio
        self.emit = emit

    async def play(self, sound: str) -> None:
        self.emit("delivery.sound", sound=sound)
        await self.audio.play(sound)

    async def stop(self) -> None:
        await self.audio.stop()


class _SeenServo:
    """The box servo, each acknowledged move also an event (``delivery.box``)."""

    def __init__(self, servo: ServoBox, emit: Callable[..., None]) -> None:
        self.servo = servo
        self.emit = emit

    async def set_angle(self, angle_deg: int) -> None:
        await self.servo.set_angle(angle_deg)
        self.emit("delivery.box", angle_deg=angle_deg)


class DeliveryProfile(BaseProfile):
    name = "delivery"
    devices = ("motors", "encoders", "lidar", "servo", "leds", "audio", "qr")

    def __init__(self) -> None:
        self.nav: NavStack | None = None
        self.mission: DeliveryMission | None = None
        self.recovery: ErrorRecovery | None = None
        self.outputs: StateOutputs | None = None
        self.memory: DeliveryMemory | None = None
        self.box: BoxController | None = None
        self._previous = "boot"

    # -- tables --------------------------------------------------------------------------------
    def mission_states(self) -> list[str | dict[str, Any]]:
        return states.mission_states()

    def mission_transitions(self) -> list[dict[str, Any]]:
        return [{**t, "before": "delivery_moved"}
                for t in [*states.mission_transitions(), *RESUME_TRANSITIONS]]

    def mission_records(self) -> tuple[MissionRecord, ...]:
        return (DELIVERY_MISSION, POSE_RECORD)

    def control_methods(self, ctx: RobotContext) -> dict[str, ControlMethod]:
        return LoadingConfirmation(ctx).methods()

    # -- services ------------------------------------------------------------------------------
    def services(self, ctx: RobotContext) -> list[Service]:
        d = ctx.devices
        if d.encoders is None or d.motors is None or d.lidar is None:
            msg = "the delivery profile needs motors, encoders and a lidar"
            raise RuntimeError(msg)
        s = ctx.settings
        odometry = Odometry.from_settings(ctx.settings)
        stored = stored_pose(ctx.persisted(POSE_RECORD).values())
        motors = CommandedMotors(d.motors)  # under the guard: what reaches the board
        nav = self.nav = NavStack(s, motors, d.lidar, odometry, front_range=d.front_range,
                                  stored_pose=stored, emit=ctx.emit,
                                  telemetry=ctx.telemetry)
        ctx.emit("nav.start", initial_pose=nav.started_from,
                 particles=len(nav.localiser.particles),
                 map_resolution_m=nav.planner.grid.resolution_m)
        orders = SqliteOrders(self._database(ctx, str(s.get("delivery.database_url"))))
        memory = self.memory = DeliveryMemory(ctx.persisted(DELIVERY_MISSION))
        timers = timers_from(s)
        home = (float(s.get("delivery.home_x_m")), float(s.get("delivery.home_y_m")))
        places = Places(
            home=home,
            warehouse=(float(s.get("delivery.warehouse_x_m")),
                       float(s.get("delivery.warehouse_y_m"))),
            zone_radius_m=float(s.get("delivery.zone_radius_m")),
            tolerance_m=float(s.get("delivery.position_tolerance_m")),
            approach_m=float(s.get("delivery.approach_distance_m")),
            delivery_s=timers.delivery_duration_s, verifying_s=timers.verifying_timeout_s,
            loading_s=timers.loading_timeout_s, delivering_limit_s=timers.delivering_timeout_s)

        async def mark(order_id: int) -> None:
            await orders.mark_delivered(order_id, ctx.wall_clock().isoformat())

        self.mission = DeliveryMission(nav, OrderVerifier(orders), memory, places, mark,
                                       NavErrors(nav, d.front_range))
        self.recovery = ErrorRecovery(nav, memory, home, self.mission.good)
        self.mission.good.watch()
        box = self.box = BoxController(_SeenServo(d.servo, ctx.emit), ctx.emit,
                            telemetry=ctx.telemetry) if d.servo is not None else None
        audio = _HeardAudio(d.audio, ctx.emit) if d.audio is not None else None
        outputs = self.outputs = StateOutputs(d.leds, box, audio)

        async def autostart() -> None:
            """The mission starts once localisation runs: waiting at home."""
            nav.watch_scans()
            await ctx.trigger(CoreTrigger.START_MISSION)
            await asyncio.Event().wait()

        return [
            TaskService("odometry", OdometryTracker(d.encoders, odometry).run, critical=True),
            TaskService("encoder_watch", _encoder_watch(ctx, nav, d.encoders, motors,
                                                        self.mission.errors).run),
            NavLocalisation(nav),
            TaskService("delivery.outputs", outputs.run),
            TaskService("delivery.poses", lambda: _pose_events(ctx, nav),
                        depends_on=("localisation",)),
            TaskService("delivery.autostart", autostart, depends_on=("localisation",)),
        ]

    @staticmethod
    def _database(ctx: RobotContext, url: str) -> Path:
        from pathlib import Path

        return sqlite_path(url, Path(str(ctx.settings.get("robot.state_dir"))))

    # -- tasks and hooks -----------------------------------------------------------------------
    def state_tasks(self) -> dict[str, StateTask]:
        p, m = states.path, DeliveryMission
        return {
            p(states.WAITING): self._task(m.waiting),
            p(states.APPROACHING): self._task(m.approaching),
            p(states.VERIFYING): self._task(m.verifying),
            p(states.TO_WAREHOUSE): self._task(m.to_warehouse),
            p(states.LOADING): self._task(m.loading),
            p(states.TO_CUSTOMER): self._task(m.to_customer),
            p(states.DELIVERING): self._task(m.delivering),
            p(states.RESETTING): self._task(m.resetting),
            p(states.ERROR_RECOVERY): self._recover,
        }

    def _task(self, step: Callable[[DeliveryMission, RobotContext], Awaitable[None]]
              ) -> StateTask:
        async def run(ctx: RobotContext) -> None:
            mission = self.mission
            if mission is None:
                return  # services not built (a table-only test)
            await step(mission, ctx)
        return run

    async def _recover(self, ctx: RobotContext) -> None:
        if self.recovery is not None:
            await self.recovery.run(ctx)

    def on_enter(self, state: str, ctx: RobotContext) -> None:
        if state == states.path(states.WAITING) and not self._previous.startswith("mission"):
            self._post(self._previous, CoreTrigger.START_MISSION, states.WAITING)

    def on_exit(self, state: str, ctx: RobotContext) -> None:
        self._previous = state

    def delivery_moved(self, event: Any) -> None:
        """As each mission transition starts: its outputs queued, the error's category kept
        (before the new state's task reads it)."""
        src = _relative(str(event.transition.source))
        dst = _relative(str(event.transition.dest))
        trigger = str(event.event.name)
        if dst == states.ERROR_RECOVERY and self.recovery is not None:
            category = event.kwargs.get("category")
            if trigger == CoreTrigger.TIMEOUT:
                category = f"{src}_timeout"
            self.recovery.category = str(category or trigger)
        self._post(src, trigger, dst)

    def _post(self, src: str, trigger: str, dst: str) -> None:
        if self.outputs is None:
            return
        order_id = self.memory.order_id if self.memory is not None else None
        self.outputs.post(states.outputs_for(_relative(src), trigger, dst, order_id))

    def mission_status(self) -> dict[str, Any]:
        """The order in hand for ``robotctl status`` (``mission.*`` rows): order, customer
        position, parcel in the box, box angle, the last error category."""
        if self.memory is None:
            return {}
        m = self.memory.values()
        customer = self.memory.customer_position()
        return {"order_id": m["order_id"],
                "customer": None if customer is None else [round(v, 3) for v in customer],
                "parcel_in_box": self.memory.parcel_in_box,
                "box_angle_deg": None if self.box is None else self.box.angle_deg,
                "last_error": m["last_error"]}

    def site_facts(self, ctx: RobotContext) -> SiteFacts:
        """The map pose, the order in hand, and in ``error_recovery`` the seed's error
        category as the fault (what the site's staff are alerted to)."""
        order_id = self.memory.order_id if self.memory is not None else None
        job = f"order {order_id}" if order_id is not None else None
        facts = self.nav.site_facts(job) if self.nav is not None else SiteFacts(job=job)
        if ctx.state == states.path(states.ERROR_RECOVERY) and self.recovery is not None:
            category = self.recovery.category or "unknown"
            facts = replace(facts, fault=Fault(category, f"error recovery: {category}"))
        return facts

    def status(self) -> dict[str, Any]:
        """Navigation figures and the order in hand, for ``robotctl status``."""
        if self.nav is None:
            return {}
        out = self.nav.status()
        if self.memory is not None:
            out["delivery"] = self.memory.values()
        return out


def _encoder_watch(ctx: RobotContext, nav: NavStack, encoders: Encoders,
                   motors: CommandedMotors, errors: NavErrors) -> EncoderWatch:
    """The seed's encoder failure: an error event (category ``encoder``), LiDAR-only
    localisation and half speed while the counters are frozen; the mission goes on (a goal
    that then makes no progress is a motor failure: ``recovery.category_of``)."""

    def changed(failed: bool, figures: dict[str, Any]) -> None:
        nav.encoders_failed(failed)
        errors.encoders_failed = failed
        ctx.emit("odometry.encoders_failed" if failed else "odometry.encoders_back",
                 state=ctx.state, **figures)

    s = ctx.settings
    config = EncoderWatchConfig(freeze_s=float(s.get("delivery.encoder_freeze_s")),
                                min_pwm=int(s.get("delivery.encoder_min_pwm")))
    return EncoderWatch(encoders, motors.commanded_pwm, changed, config)


async def _pose_events(ctx: RobotContext, nav: NavStack, period_s: float = 0.5) -> None:
    """``nav.pose`` (the estimate, its spread and status) for the record and the report; the
    pose kept in the store while localised."""
    loop = asyncio.get_running_loop()
    stored_s = loop.time()
    while True:
        await asyncio.sleep(period_s)
        if nav.service.poses.latest() is None:
            continue  # not publishing yet
        pose = nav.live_pose()
        if loop.time() - stored_s >= _STORE_POSE_S and pose.status == LOCALISED:
            stored_s = loop.time()
            ctx.persisted(POSE_RECORD).set(x_m=round(pose.x_m, 4), y_m=round(pose.y_m, 4),
                                           heading_rad=round(pose.theta_rad, 5))
        ctx.emit("nav.pose", est_x_m=round(pose.x_m, 4), est_y_m=round(pose.y_m, 4),
                 est_heading_deg=round(math.degrees(pose.theta_rad), 2), status=pose.status,
                 spread_m=round(min(pose.spread_m, 99.0), 4), particles=pose.particles,
                 poses_published=nav.poses_published)


def _relative(state: str) -> str:
    return state.removeprefix("mission.")
