"""Monte Carlo localisation fused with wheel odometry: the robot's pose on the map.

``Localiser`` is the filter with no I/O: each LiDAR scan comes with the odometry pose of the
moment; once the robot has moved ``update_min_d_m`` or turned ``update_min_a_rad`` since the
last update (AMCL's rule), the particles are moved by the odometry step (motion model),
weighed by the likelihood field, resampled, and the correction ``map <- odom`` is renewed.
Between scans the pose is that correction composed with live odometry, so it can be published
at any rate (seed property 15: >= 10 Hz). Health is judged on every scan: the particle spread
and the share of beams that match the map at the fused pose; past their limits for
``diverged_s`` the filter is ``diverged`` (the profile decides what to do). With the LiDAR
stale the pose runs on odometry alone, for ``lidar_lost_max_s`` at most, then ``lidar_lost``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import structlog

from behaviours.nav.localisation.config import LocalisationConfig
from behaviours.nav.localisation.lidar_only import LidarOnlyMotion
from behaviours.nav.localisation.likelihood_field import (
    BeamModel,
    DistanceGrid,
    LikelihoodField,
    select_beams,
)
from behaviours.nav.localisation.motion_model import compose, inverse, sample_odometry_motion, wrap
from behaviours.nav.localisation.particles import Estimate, ParticleSet
from hal.readings import LidarScan

log = structlog.get_logger(__name__)

FloatArray = npt.NDArray[np.float64]
OdomPose = tuple[float, float, float]

JUMP_M = 0.5
JUMP_RAD = math.radians(20)
"""An update that moves a settled filter's pose this far is a jump (``jumps``): a robot
carried off, or the filter gone to a look-alike place; either way, lost."""
SETTLE_UPDATES = 5
"""Scans that update a re-seeded filter though the robot stands still (``mark_uncertain``)."""
_ROUGHEN_M = 0.02
_ROUGHEN_RAD = math.radians(1.0)

LOCALISED = "localised"
UNCERTAIN = "uncertain"  # past a limit, not yet for diverged_s
DIVERGED = "diverged"
ODOMETRY_ONLY = "odometry_only"
LIDAR_LOST = "lidar_lost"


@dataclass(frozen=True, slots=True)
class LocalisedPose:
    """What the localiser publishes: the map pose now, and how far to trust it."""

    x_m: float
    y_m: float
    theta_rad: float
    t_s: float
    status: str
    spread_m: float
    spread_rad: float
    match_fraction: float
    particles: int

    def as_dict(self) -> dict[str, float | int | str]:
        return {"x_m": round(self.x_m, 4), "y_m": round(self.y_m, 4),
                "heading_deg": round(math.degrees(self.theta_rad), 2), "t_s": self.t_s,
                "status": self.status, "spread_m": round(self.spread_m, 4),
                "spread_deg": round(math.degrees(self.spread_rad), 2),
                "match_fraction": round(self.match_fraction, 3), "particles": self.particles}


class Localiser:
    """The particle filter on one map, and the pose it fuses with odometry."""

    def __init__(self, grid: DistanceGrid, config: LocalisationConfig) -> None:
        self.config = config
        self.grid = grid
        self.field = LikelihoodField(grid, BeamModel(
            z_hit=config.z_hit, z_rand=config.z_rand, sigma_hit_m=config.sigma_hit_m,
            max_dist_m=config.likelihood_max_dist_m, max_range_m=config.laser_max_range_m,
            max_beams=config.max_beams, combine=config.beam_combine))
        self.rng = np.random.default_rng(config.seed)
        rows, cols = np.nonzero(grid.free_cells())
        self._free_rows, self._free_cols = rows, cols
        self.particles = ParticleSet(np.zeros((0, 3)))
        self.correction: FloatArray = np.zeros(3)
        self.estimate: Estimate | None = None
        self._odom_at_update: OdomPose | None = None
        self.updates = 0
        self.scans = 0
        self.rejected = 0
        self.match_fraction = 0.0
        self.last_scan_s: float | None = None
        self._bad_since_s: float | None = None
        self._stale_since_s: float | None = None
        self.status = UNCERTAIN
        self.divergences = 0
        self.lidar_only: LidarOnlyMotion | None = None  # encoders failed: lidar_only.py
        self._settle = 0  # updates still owed to a re-seeded filter standing still
        self._resample_due = False  # on_scan(defer_resample=True) left it to finish_update()
        self._settled = False  # localised since the last (re)start: jumps count from then
        self.jumps = 0
        self.last_jump: tuple[float, float] = (0.0, 0.0)
        """(metres, radians) the last jump moved the pose."""

    # --- starting -------------------------------------------------------------------------

    def start_at(self, x_m: float, y_m: float, theta_rad: float, sigma_m: float | None = None,
                 sigma_rad: float | None = None) -> None:
        """Particles in a Gaussian cloud around a pose (AMCL's initial pose)."""
        self.finish_update()  # the random draws stay in the order they had without deferral
        c = self.config
        s_m = c.initial_sigma_m if sigma_m is None else sigma_m
        s_rad = c.initial_sigma_rad if sigma_rad is None else sigma_rad
        n = c.max_particles
        noise = self.rng.standard_normal((n, 3))
        poses = np.column_stack((x_m + s_m * noise[:, 0], y_m + s_m * noise[:, 1],
                                 wrap(theta_rad + s_rad * noise[:, 2])))
        self._restart(poses, (x_m, y_m, theta_rad))
        log.info("localisation.start", x_m=x_m, y_m=y_m, heading_deg=math.degrees(theta_rad),
                 sigma_m=s_m, particles=n)

    def start_global(self) -> None:
        """Particles spread uniformly over the map's free space (global localisation)."""
        self.finish_update()
        poses = self.sample_free(self.config.global_particles)
        self._restart(poses, None)
        log.info("localisation.start_global", particles=len(self.particles),
                 free_cells=int(self._free_rows.shape[0]))

    def start_from(self, poses: FloatArray) -> None:
        """Particles given (a global search's candidates): the next scan weighs them all, then
        the filter runs on ``max_particles``, as after a global start."""
        self.finish_update()
        self._restart(np.asarray(poses, dtype=np.float64).reshape(-1, 3), None)
        log.info("localisation.start_from", particles=len(self.particles))

    def mark_uncertain(self) -> None:
        """Re-seeded (an operator's pose, a relocalisation): not judged yet, so neither
        localised nor diverged until the next scan says; the next ``SETTLE_UPDATES`` scans
        update the filter even if the robot stands still (each with a little roughening, as
        no motion spreads the particles), so a robot put down by hand settles where it is."""
        self._bad_since_s = None
        self._settle = SETTLE_UPDATES
        self._set_status(UNCERTAIN)

    def _restart(self, poses: FloatArray, guess: OdomPose | None) -> None:
        self.particles = ParticleSet(poses)
        self._odom_at_update = None
        self._settled = False
        self.estimate = (None if guess is None
                         else Estimate(guess[0], guess[1], guess[2], math.inf, math.inf))
        self._bad_since_s = None

    def sample_free(self, count: int) -> FloatArray:
        """``count`` poses uniform over the free cells, any heading."""
        g = self.grid
        if self._free_rows.shape[0] == 0:
            msg = "the map has no free cell to localise in"
            raise ValueError(msg)
        pick = self.rng.integers(0, self._free_rows.shape[0], count)
        jitter = self.rng.random((count, 3))
        x = g.origin_x_m + (self._free_cols[pick] + jitter[:, 0]) * g.resolution_m
        y = g.origin_y_m + (self._free_rows[pick] + jitter[:, 1]) * g.resolution_m
        theta = (jitter[:, 2] * 2 - 1) * math.pi
        return np.column_stack((x, y, theta))

    # --- scans ----------------------------------------------------------------------------

    def on_scan(self, odom: OdomPose, scan: LidarScan, now_s: float, *,
                defer_resample: bool = False) -> bool:
        """Take one scan with the odometry pose of its time; True if the filter updated.

        A malformed scan (angles and ranges of different shapes) or a non-finite odometry
        pose is counted in ``rejected`` and skipped. ``defer_resample`` leaves the resampling
        (a third of an update's work) to ``finish_update``, for a caller that runs it as a
        loop step of its own: the pose, the estimate and the status are already this scan's.
        """
        self.finish_update()
        if (scan.angles_rad.shape != scan.ranges_m.shape or scan.ranges_m.ndim != 1
                or not all(math.isfinite(v) for v in odom)):
            self.rejected += 1
            log.warning("localisation.rejected", count=self.rejected,
                        angles=scan.angles_rad.shape, ranges=scan.ranges_m.shape, odom=odom)
            return False
        self.scans += 1
        self.last_scan_s = now_s
        self._stale_since_s = None
        beams = select_beams(scan, self.config.max_beams, self.config.laser_max_range_m)
        updated = False
        if len(self.particles) and (self.lidar_only is not None or self._moved_enough(odom)):
            self._update(odom, beams, defer_resample)
            updated = True
        elif len(self.particles) and self._settle > 0:
            self._settle -= 1
            self._roughen()
            self._update(odom, beams, defer_resample)
            updated = True
        self.match_fraction = self.field.match_fraction(
            self.pose_array(odom), beams, self.config.match_distance_m)
        self._judge(now_s)
        return updated

    def _moved_enough(self, odom: OdomPose) -> bool:
        last = self._odom_at_update
        if last is None:
            return True
        c = self.config
        return (math.hypot(odom[0] - last[0], odom[1] - last[1]) >= c.update_min_d_m
                or abs(math.remainder(odom[2] - last[2], 2 * math.pi)) >= c.update_min_a_rad)

    def _roughen(self) -> None:
        ps = self.particles
        noise = self.rng.standard_normal(ps.poses.shape)
        ps.poses = ps.poses + noise * np.array([_ROUGHEN_M, _ROUGHEN_M, _ROUGHEN_RAD])
        ps.poses[:, 2] = wrap(ps.poses[:, 2])

    def _update(self, odom: OdomPose, beams: FloatArray, defer_resample: bool = False) -> None:
        c = self.config
        ps = self.particles
        if self.lidar_only is not None:
            ps.poses = self.lidar_only.predict(ps.poses, self.rng)
        elif self._odom_at_update is not None:
            ps.poses = sample_odometry_motion(ps.poses, self._odom_at_update, odom, c.alphas,
                                              self.rng)
        factors, likelihoods = self.field.weights(ps.poses, beams)
        ps.weigh(factors, likelihoods, c.alpha_slow, c.alpha_fast)
        before = self.pose_array(odom)
        self.estimate = ps.estimate()
        self._note_jump(before)
        if self.lidar_only is not None:
            self.lidar_only.estimated(self.estimate.as_array())
        self.correction = compose(self.estimate.as_array(), inverse(np.asarray(odom)))
        self._resample_due = True
        if not defer_resample:
            self.finish_update()
        self._odom_at_update = odom
        self.updates += 1

    def finish_update(self) -> None:
        """The resampling the last update owes, if any (``on_scan(defer_resample=True)``)."""
        if not self._resample_due:
            return
        self._resample_due = False
        c = self.config
        self.particles.resample(self.rng, self.sample_free, kld_err=c.kld_err, kld_z=c.kld_z,
                                min_particles=c.min_particles, max_particles=c.max_particles,
                                recover=c.alpha_slow > 0 and c.alpha_fast > 0)

    def _note_jump(self, before: FloatArray) -> None:
        est = self.estimate
        if est is None or not self._settled:
            return
        jump_m = math.hypot(est.x_m - before[0], est.y_m - before[1])
        jump_rad = abs(math.remainder(est.theta_rad - before[2], 2 * math.pi))
        if jump_m >= JUMP_M or jump_rad >= JUMP_RAD:
            self.jumps += 1
            self.last_jump = (jump_m, jump_rad)
            log.warning("localisation.jump", jump_m=round(jump_m, 3),
                        jump_deg=round(math.degrees(jump_rad), 1), status=self.status)

    def set_lidar_only(self, on: bool, odom: OdomPose) -> None:
        """LiDAR-only (the encoders failed: ``lidar_only.py``) or back on odometry."""
        if on == (self.lidar_only is not None):
            return
        if on:
            self.lidar_only = LidarOnlyMotion()
            log.warning("localisation.lidar_only", on=True)
            return
        motion, self.lidar_only = self.lidar_only, None
        anchor = self._odom_at_update  # the odometry pose the correction was last renewed on
        if anchor is not None:  # the pose as it stands, now on the returned odometry
            pose = self.pose_array(anchor)
            self.correction = compose(pose, inverse(np.asarray(odom, dtype=np.float64)))
        self._odom_at_update = odom
        log.info("localisation.lidar_only", on=False,
                 updates=motion.updates if motion is not None else 0)

    # --- the pose and its health ----------------------------------------------------------

    def pose_array(self, odom: OdomPose) -> FloatArray:
        """The map pose now: the last correction composed with live odometry."""
        return compose(self.correction, np.asarray(odom, dtype=np.float64))

    def pose(self, odom: OdomPose, now_s: float) -> LocalisedPose:
        p = self.pose_array(odom)
        est = self.estimate
        return LocalisedPose(
            float(p[0]), float(p[1]), float(p[2]), now_s, self.status,
            est.spread_m if est else math.inf, est.spread_rad if est else math.inf,
            self.match_fraction, len(self.particles))

    def _judge(self, now_s: float) -> None:
        c = self.config
        est = self.estimate
        bad = (est is None or est.spread_m > c.max_spread_m or est.spread_rad > c.max_spread_rad
               or self.match_fraction < c.min_match_fraction)
        if not bad:
            self._bad_since_s = None
            self._settled = True
            self._set_status(LOCALISED)
            return
        if self._bad_since_s is None:
            self._bad_since_s = now_s
        if now_s - self._bad_since_s >= c.diverged_s:
            self._set_status(DIVERGED)
        elif self.status != DIVERGED:
            self._set_status(UNCERTAIN)

    def lidar_stale(self, now_s: float) -> None:
        """The LiDAR sent nothing for its stale time: odometry only, then an error."""
        if self._stale_since_s is None:
            self._stale_since_s = now_s
        if now_s - self._stale_since_s >= self.config.lidar_lost_max_s:
            self._set_status(LIDAR_LOST)
        elif self.status != LIDAR_LOST:
            self._set_status(ODOMETRY_ONLY)

    def _set_status(self, status: str) -> None:
        if status == self.status:
            return
        est = self.estimate
        fields = {"old": self.status, "new": status, "match_fraction": self.match_fraction,
                  "spread_m": est.spread_m if est else None}
        if status == DIVERGED:
            self.divergences += 1
        if status in (DIVERGED, LIDAR_LOST):
            log.error("localisation.status", **fields)
        else:
            log.info("localisation.status", **fields)
        self.status = status
