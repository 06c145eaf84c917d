"""A differential-drive robot body: motors that answer PWM, wheels that slip, a battery.

The body implements ``MotorPlant``: the simulated motor board sets PWM on it and reads its
encoders, front range and battery. ``step(dt_s)`` advances the physics; the simulator calls it
at a fixed rate on the event loop's clock.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from sim.world.floor_plan import World
from sim.world.geometry import Pose, raycast_one, segment_distances
from sim.world.vacuum import VacuumParts

_TWO_PI = 2 * math.pi
_MATH = (math.cos, math.sin, math.pi)
_SLIP_BLOCK = 1024  # slip factors drawn at once: 512 moving steps, ~5 s of driving
_FEW_WALLS = 64  # fewer walls than this: the front sensor's ray meets them all
_NEAR_M = 4.0  # else the walls within this of where the robot was are kept for its ray


@dataclass(frozen=True, slots=True)
class BodyParams:
    wheel_base_m: float = 0.30
    wheel_radius_m: float = 0.035
    ticks_per_rev: int = 360
    max_wheel_speed_mps: float = 0.6  # at PWM 255
    deadband_pwm: int = 20  # below this the motors do not turn (static friction)
    motor_tau_s: float = 0.08  # first-order lag of wheel speed
    slip_std: float = 0.01  # relative ground-speed error per wheel, per step
    radius_m: float = 0.18  # footprint, for collisions
    range_max_cm: float = 150.0  # front IR sensor (Sharp GP2Y0A02: 20-150 cm)
    range_min_cm: float = 20.0
    range_noise_cm: float = 1.0
    battery_wh: float = 40.0
    idle_w: float = 3.0
    motor_w: float = 12.0  # per wheel at full duty
    charge_w: float = 30.0
    # A vacuum (``cleans``): brushes and suction run while its wheels turn off the dock.
    cleans: bool = False
    clean_w: float = 15.0
    bin_fill_pct_per_m: float = 0.5  # dust picked up per metre cleaned (200 m fill the bin)
    evac_pct_per_s: float = 6.0  # the station's suction empties a full bin in ~17 s
    bin_door_open_deg: int = 60  # the bin door is the box servo: open at or past this angle


@dataclass(frozen=True, slots=True)
class Collision:
    t_s: float
    x_m: float
    y_m: float


class DiffDriveBody(VacuumParts):
    """One robot's body on the floor plan.

    With a ``clock`` (the event loop's ``time``), the body integrates itself up to the clock's
    time in ``dt_s`` steps whenever it is touched (a PWM change, an encoder read, a pose read),
    so no timer has to wake the loop a hundred times a second. Without one, ``step`` is called
    by hand (tests).
    """

    params: BodyParams

    def __init__(self, world: World, pose: Pose, params: BodyParams | None = None, *,
                 rng: random.Random | None = None, charge_pct: float = 100.0,
                 payload_kg: float = 0.0, clock: Callable[[], float] | None = None,
                 dt_s: float = 0.01) -> None:
        self.world = world
        # The pose as plain floats: the physics moves it 100 times a second, a Pose object is
        # only built when somebody reads it.
        self._xyh = (pose.x_m, pose.y_m, pose.heading_rad)
        self._pose_obj: Pose | None = pose
        self.params = params or BodyParams()
        self.rng = rng or random.Random()
        self.charge_pct = charge_pct
        self.payload_kg = payload_kg
        self.servo_deg = 0
        self.pwm: tuple[int, int, bool, bool] = (0, 0, True, True)
        self.wheel_mps = [0.0, 0.0]
        self.collisions: list[Collision] = []
        self.distance_m = 0.0
        self.time_s = 0.0
        self.dt_s = dt_s
        self._clock = clock
        self._synced_s = clock() if clock is not None else 0.0
        self._ticks = [0.0, 0.0]
        self._in_contact = False
        self._free_m = -1.0  # distance it can move before walls must be checked again
        self.others: list[DiffDriveBody] = []  # other robots, seen by the front sensor
        self._consts: tuple[Any, ...] = (None, None, None)
        self._targets_pwm: tuple[int, int, bool, bool] | None = None
        self._targets = (0.0, 0.0)
        self._dock_xyh: tuple[float, float, float] | None = None  # ``_on_dock`` is for this
        self._on_dock = False
        self._walls_list: tuple[npt.NDArray[np.float64], list[Any],
                                tuple[float, float, list[Any]] | None] | None = None
        self._slips: list[float] = []  # 1 + slip, two a moving step (``_draw_slips``)
        self._slip_i = 0
        self._slip_source = _slip_source(self.rng)
        self._slip_rng = self.rng
        self._bin_pct = 0.0

    @property
    def pose(self) -> Pose:
        self.sync()
        return self._pose_now()

    @pose.setter
    def pose(self, value: Pose) -> None:
        self.sync()
        self._xyh = (value.x_m, value.y_m, value.heading_rad)
        self._pose_obj = value
        self._free_m = -1.0

    def sync(self) -> None:
        """Integrate up to the clock's time (no-op without a clock)."""
        if self._clock is None:
            return
        now = self._clock()
        if now - self._synced_s >= self.dt_s:
            self._integrate(self.dt_s, now)

    # --- MotorPlant -------------------------------------------------------------------------
    def apply_pwm(self, left_pwm: int, right_pwm: int, left_forward: bool,
                  right_forward: bool) -> None:
        self.sync()
        self.pwm = (left_pwm, right_pwm, left_forward, right_forward)

    def encoder_ticks(self) -> tuple[int, int]:
        self.sync()
        return math.floor(self._ticks[0]), math.floor(self._ticks[1])

    def front_range_cm(self) -> float:
        p = self.params
        pose = self.pose
        x, y = pose.to_world(p.radius_m, 0.0)
        range_m = p.range_max_cm / 100
        hit_m = raycast_one(self._walls_near(x, y, range_m), x, y, pose.heading_rad, range_m)
        for person in self.world.people:
            if person.present:
                hit_m = min(hit_m, _ray_circle(x, y, pose.heading_rad,
                                               person.x_m, person.y_m, person.radius_m))
        for other in self.others:
            o = other.pose
            hit_m = min(hit_m, _ray_circle(x, y, pose.heading_rad, o.x_m, o.y_m,
                                           other.params.radius_m))
        cm = hit_m * 100 + self.rng.gauss(0, p.range_noise_cm)
        return float(min(p.range_max_cm, max(p.range_min_cm, cm)))

    def _walls_near(self, x_m: float, y_m: float, range_m: float
                    ) -> list[tuple[float, float, float, float]]:
        """The walls a ray of ``range_m`` from (x, y) can meet, as a list (``raycast_one``).

        A map's world has thousands of cell sides: the ones within ``_NEAR_M`` of a centre are
        kept and reused until the robot is within ``range_m`` of that circle's edge. Order
        is kept, so the nearest hit (the first of equals) is the one all the walls give."""
        walls = self.world.walls
        cached = self._walls_list
        if cached is None or cached[0] is not walls:
            cached = self._walls_list = (walls, walls.tolist(), None)
        if walls.shape[0] <= _FEW_WALLS:
            return cached[1]
        near = cached[2]
        if near is not None and math.hypot(x_m - near[0], y_m - near[1]) + range_m <= _NEAR_M:
            return near[2]
        keep = np.flatnonzero(segment_distances(walls, x_m, y_m) <= _NEAR_M)
        listed = [cached[1][i] for i in keep.tolist()]
        self._walls_list = (walls, cached[1], (x_m, y_m, listed))
        return listed

    def battery(self) -> tuple[float, float, bool]:
        # A 3S Li-ion pack: 9.6 V empty to 12.6 V full, close enough to linear for a sim.
        self.sync()
        voltage = 9.6 + 3.0 * self.charge_pct / 100
        return voltage, self.charge_pct, self.on_dock

    def _pose_now(self) -> Pose:
        if self._pose_obj is None:
            self._pose_obj = Pose(*self._xyh)
        return self._pose_obj

    def servo(self, angle_deg: int) -> None:
        self.sync()  # the bin door (a vacuum's servo) moves now, not at the last sync
        self.servo_deg = angle_deg

    # --- physics ----------------------------------------------------------------------------
    @property
    def on_dock(self) -> bool:
        return self._docked(*self._xyh)

    def _docked(self, x_m: float, y_m: float, heading_rad: float) -> bool:
        """Charging: both front contacts on the dock's pads, and the pads not faulty."""
        dock = self.world.dock
        if dock is None:
            return False
        return dock.charges(Pose(x_m, y_m, heading_rad), self.params.radius_m)

    def _target_mps(self, pwm: int, forward: bool) -> float:
        p = self.params
        if pwm <= p.deadband_pwm:
            return 0.0
        duty = (pwm - p.deadband_pwm) / (255 - p.deadband_pwm)
        return duty * p.max_wheel_speed_mps * (1 if forward else -1)

    def step(self, dt_s: float) -> None:
        """Advance the physics by one step of ``dt_s`` (bodies without a clock)."""
        self._integrate(dt_s, None)

    def _integrate(self, dt_s: float, until_s: float | None) -> None:
        """Steps of ``dt_s``: one (``until_s`` None), or as many as the clock is ahead.

        A hundred steps per simulated second per robot: the state lives in local variables
        while it runs, and what depends only on the parameters, the generator, the PWM and dt
        is worked out once (same expressions in the same order as a step at a time, so the
        same floats).
        """
        p = self.params
        rng = self.rng
        consts = self._consts
        if consts[0] is not p or consts[1] != dt_s or consts[2] is not rng:
            consts = self._consts = self._constants(p, dt_s, rng)
            self._targets_pwm = None
            self._slips, self._slip_i = [], 0
            if self._slip_rng is not rng:
                self._slip_source, self._slip_rng = _slip_source(rng), rng
        _, _, _, blend, per_tick_m, slip_std, wheel_base_m, radius_m = consts
        pwm = self.pwm
        if self._targets_pwm != pwm:
            self._targets_pwm = pwm
            self._targets = (self._target_mps(pwm[0], pwm[2]), self._target_mps(pwm[1], pwm[3]))
        target_left, target_right = self._targets
        slips = self._slips
        slip_i = self._slip_i
        cos, sin, pi = _MATH
        has_dock = self.world.dock is not None
        left, right = self.wheel_mps
        ticks_left, ticks_right = self._ticks
        xyh = self._xyh
        x, y, heading = xyh
        time_s = self.time_s
        synced_s = self._synced_s
        charge = self.charge_pct
        free_m = self._free_m
        in_contact = self._in_contact
        distance_m = self.distance_m
        # With a dock the contacts can fail or the dock move at any time: look afresh.
        if has_dock:
            on_dock = self._docked(x, y, heading)
        else:
            on_dock = self._on_dock if xyh is self._dock_xyh else False
        start_s, start_distance_m = time_s, distance_m
        drain_pct = self._drain_for(pwm, on_dock, dt_s)
        stepped = False
        while True:
            if until_s is None:
                if stepped:
                    break
                stepped = True
            elif until_s - synced_s >= dt_s:
                synced_s += dt_s
            else:
                break
            time_s += dt_s
            if left == 0.0 and right == 0.0 and target_left == 0 and target_right == 0:
                charge -= drain_pct  # standing still: nothing turns, nothing moves
                if charge < 0.0:
                    charge = 0.0
                elif charge > 100.0:
                    charge = 100.0
                continue
            left += (target_left - left) * blend
            if target_left == 0 and -1e-5 < left < 1e-5:
                left = 0.0
            right += (target_right - right) * blend
            if target_right == 0 and -1e-5 < right < 1e-5:
                right = 0.0
            left_m = left * dt_s
            right_m = right * dt_s
            ticks_left += left_m / per_tick_m
            ticks_right += right_m / per_tick_m
            if left_m or right_m:
                if slip_i == len(slips):
                    slips = self._slips = _draw_slips(self._slip_source, slip_std)
                    slip_i = 0
                left_m *= slips[slip_i]
                right_m *= slips[slip_i + 1]
                slip_i += 2
            if left_m != 0 or right_m != 0:
                d = (left_m + right_m) / 2
                dtheta = (right_m - left_m) / wheel_base_m
                mid = heading + dtheta / 2
                new_x = x + d * cos(mid)
                new_y = y + d * sin(mid)
                heading = (heading + dtheta + pi) % _TWO_PI - pi  # wrap_angle
                step_m = abs(d)
                free_m -= step_m
                blocked = False
                if free_m <= 0:
                    clearance = self.world.clearance_m(new_x, new_y)
                    free_m = clearance - radius_m
                    if clearance < radius_m and clearance < self.world.clearance_m(x, y):
                        if not in_contact:
                            self.collisions.append(Collision(time_s, new_x, new_y))
                        in_contact = True
                        free_m = -1.0
                        blocked = True
                    elif has_dock:
                        blocked, by_body, free_m = self._dock_stops(x, y, new_x, new_y, free_m)
                        if by_body and not in_contact:
                            self.collisions.append(Collision(time_s, new_x, new_y))
                        in_contact = in_contact or by_body
                if not blocked:
                    in_contact = False
                    distance_m += step_m
                    x = new_x
                    y = new_y
                if has_dock:
                    docked = self._docked(x, y, heading)
                    if docked != on_dock:
                        on_dock = docked
                        drain_pct = self._drain_for(pwm, on_dock, dt_s)
            charge -= drain_pct
            if charge < 0.0:
                charge = 0.0
            elif charge > 100.0:
                charge = 100.0
        self.wheel_mps[0] = left
        self.wheel_mps[1] = right
        self._ticks[0] = ticks_left
        self._ticks[1] = ticks_right
        self.time_s = time_s
        self._synced_s = synced_s
        self.charge_pct = charge
        self._free_m = free_m
        self._in_contact = in_contact
        self.distance_m = distance_m
        if x != xyh[0] or y != xyh[1] or heading != xyh[2]:
            self._xyh = xyh = (x, y, heading)
            self._pose_obj = None
        self._dock_xyh = xyh
        self._on_dock = on_dock
        self._slip_i = slip_i
        if self.params.cleans or has_dock:
            self._dust(time_s - start_s, distance_m - start_distance_m, on_dock)

    @staticmethod
    def _constants(p: BodyParams, dt_s: float, rng: random.Random) -> tuple[Any, ...]:
        return (p, dt_s, rng, 1 - math.exp(-dt_s / p.motor_tau_s),
                2 * math.pi * p.wheel_radius_m / p.ticks_per_rev, p.slip_std, p.wheel_base_m,
                p.radius_m)

    def _drain_for(self, pwm: tuple[int, int, bool, bool], on_dock: bool,
                   dt_s: float) -> float:
        """Battery percent used per step (negative on the dock)."""
        p = self.params
        duty = (pwm[0] + pwm[1]) / 255
        watts = p.idle_w + p.motor_w * duty
        if p.cleans and duty and not on_dock:
            watts += p.clean_w
        if on_dock:
            watts -= p.charge_w
        return watts * dt_s / 3600 / p.battery_wh * 100


def _slip_source(rng: random.Random) -> random.Random:
    """The slip noise's own generator, seeded from the body's (its only draw from it)."""
    return random.Random(rng.getrandbits(64))


def _draw_slips(source: random.Random, slip_std: float) -> list[float]:
    """A block of per-wheel slip factors, 1 + N(0, slip_std), for the next moving steps.

    Box-Muller as ``Random.gauss`` does it, on 53-bit uniforms as ``Random.random`` makes
    them, but a block at once in numpy: the same statistics as one ``rng.gauss`` per wheel
    and step at a fraction of the cost (and without importing numpy.random, 30 ms). The
    draws do not depend on how often the body is synced or its range sensor read.
    """
    bits = np.frombuffer(source.randbytes(8 * _SLIP_BLOCK), dtype=np.uint64)
    uniform = (bits >> np.uint64(11)) * (1.0 / (1 << 53))
    radius = np.sqrt(-2.0 * np.log(1.0 - uniform[0::2]))
    angle = _TWO_PI * uniform[1::2]
    normals = np.concatenate((radius * np.cos(angle), radius * np.sin(angle)))
    return (normals * slip_std + 1.0).tolist()  # type: ignore[no-any-return]


def _ray_circle(x: float, y: float, heading: float, cx: float, cy: float, r: float) -> float:
    dx, dy = math.cos(heading), math.sin(heading)
    fx, fy = x - cx, y - cy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    disc = b * b - c
    if disc < 0:
        return math.inf
    t = -b - math.sqrt(disc)
    return t if t >= 0 else math.inf
