"""The ``localisation`` and ``people`` config sections, and the settings read from them.

Values are the RelayBot seed's where it gives one (section 9: 10 Hz localisation, 10 points
and 0.3 m for a person); the particle filter's are Nav2 AMCL's defaults (``nav2_params.yaml``:
alpha1-4 0.2, 60 beams, z_hit/z_rand 0.5, sigma_hit 0.2, 500-2000 particles, kld 0.05/0.99,
update_min_d 0.25 m / update_min_a 0.2 rad), except the recovery rates, which Nav2 leaves at
0 (off) and its documentation suggests 0.001 / 0.1 for: the issue asks for the recovery on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hal.options import Option, Order, Section
from hal.settings import SettingsView

opt = Option

LOCALISATION = Section("localisation", "Monte Carlo localisation on the map (behaviours.nav).", (
    opt("initial_pose", "str", "config",
        "Where the filter starts: config (initial_*), store (the last saved pose, else "
        "config), global (spread over the map's free space).",
        choices=("config", "store", "global")),
    opt("initial_x_m", "float", 0.0, "Start position x in the map frame.", min=-1e4, max=1e4),
    opt("initial_y_m", "float", 0.0, "Start position y in the map frame.", min=-1e4, max=1e4),
    opt("initial_heading_deg", "float", 0.0, "Start heading, counter-clockwise from +x.",
        min=-360, max=360),
    opt("initial_sigma_m", "float", 0.5, "Spread of the start position (AMCL: 0.5 m).",
        min=0, max=100),
    opt("initial_sigma_deg", "float", 15.0, "Spread of the start heading (AMCL: pi/12).",
        min=0, max=180),
    opt("min_particles", "int", 500, "Fewest particles (KLD sampling).", min=10, max=100000),
    opt("max_particles", "int", 2000, "Most particles (KLD sampling).", min=10, max=100000),
    opt("global_particles", "int", 20000,
        "Poses the first scan weighs after a global start (then max_particles).",
        min=10, max=1000000),
    opt("kld_err", "float", 0.05, "KLD sampling: largest error of the sample-based posterior.",
        min=0.001, max=1),
    opt("kld_z", "float", 0.99, "KLD sampling: probability that the error stays below kld_err.",
        min=0.5, max=0.9999),
    opt("alpha1", "float", 0.2, "Rotation noise from rotation (variance factor).",
        min=0, max=10, tunable=True),
    opt("alpha2", "float", 0.2, "Rotation noise from translation.", min=0, max=10,
        tunable=True),
    opt("alpha3", "float", 0.2, "Translation noise from translation.", min=0, max=10,
        tunable=True),
    opt("alpha4", "float", 0.2, "Translation noise from rotation.", min=0, max=10,
        tunable=True),
    opt("max_beams", "int", 60, "Beams of a scan the likelihood field weighs.", min=4,
        max=2000),
    opt("beam_combine", "str", "product",
        "product: the scan's likelihood (sharp); cube_sum: Nav2's 1 + sum(pz^3) (flat).",
        choices=("product", "cube_sum")),
    opt("z_hit", "float", 0.5, "Weight of the hit (Gaussian) part of the beam model.",
        min=0, max=1, tunable=True),
    opt("z_rand", "float", 0.5, "Weight of the random part of the beam model.", min=0, max=1,
        tunable=True),
    opt("sigma_hit_m", "float", 0.2, "Std of a hit's distance to the nearest obstacle.",
        min=0.001, max=5),
    opt("likelihood_max_dist_m", "float", 2.0, "Distance field cap (AMCL: 2 m).", min=0.05,
        max=50),
    opt("laser_max_range_m", "float", 12.0, "Longer beams are not weighed (LD19: 12 m).",
        min=0.1, max=100),
    opt("update_min_d_m", "float", 0.25, "Travel before a filter update.", min=0, max=10,
        tunable=True),
    opt("update_min_a_deg", "float", 11.5, "Turn before a filter update (AMCL: 0.2 rad).",
        min=0, max=180, tunable=True),
    opt("alpha_slow", "float", 0.001, "Augmented MCL: slow average of the likelihood.",
        min=0, max=1),
    opt("alpha_fast", "float", 0.1, "Augmented MCL: fast average (0 and 0: no recovery).",
        min=0, max=1),
    opt("seed", "int", 1, "Random seed of the filter (same seed, same poses).", min=0),
    opt("publish_hz", "float", 20.0,
        "Fused pose rate (seed: >= 10 Hz; 20 keeps every 1 s window at 10 or more).",
        min=10, max=200),
    opt("diverged_s", "float", 2.0,
        "Spread or scan match past its limit for this long: diverged.", min=0.1, max=600,
        tunable=True),
    opt("max_spread_m", "float", 0.5, "Position spread (std) above which it is lost.",
        min=0.01, max=100, tunable=True),
    opt("max_spread_deg", "float", 20.0, "Heading spread (std) above which it is lost.",
        min=0.1, max=180, tunable=True),
    opt("match_distance_m", "float", 0.15, "A beam within this of an obstacle matches.",
        min=0.01, max=5, tunable=True),
    opt("min_match_fraction", "float", 0.7,
        "Fewer matching beams than this at the estimate: lost (a person close by hides "
        "about 5 %; a 1 m kidnap in a room leaves about 55 %).", min=0, max=1, tunable=True),
    opt("lidar_lost_max_s", "float", 30.0,
        "Odometry alone for at most this long, then an error (seed: 30 s).", min=0,
        max=3600, tunable=True),
))
"""The particle filter's settings (Nav2 AMCL's names where it has one)."""

PEOPLE = Section("people", "People in the LiDAR scan: clusters the map does not explain.", (
    opt("cluster_gap_m", "float", 0.3, "Neighbouring points closer than this: one cluster "
        "(seed: 0.3 m).", min=0.01, max=5, tunable=True),
    opt("min_points", "int", 10,
        "Points a close person needs (seed: 10); farther, fewer (see point_fill).",
        min=1, max=1000, tunable=True),
    opt("min_points_floor", "int", 3, "Never fewer points than this, at any range.", min=1,
        max=1000, tunable=True),
    opt("point_fill", "float", 0.5,
        "A cluster needs this fraction of the points its width spans at its range.",
        min=0, max=1, tunable=True),
    opt("unexplained_m", "float", 0.2,
        "A point this far from every occupied map cell is not the map's.", min=0.01, max=5,
        tunable=True),
    opt("leg_min_width_m", "float", 0.05, "Narrowest leg.", min=0, max=5, tunable=True),
    opt("leg_max_width_m", "float", 0.25, "Widest leg.", min=0, max=5, tunable=True),
    opt("body_min_width_m", "float", 0.3, "Narrowest body (or two legs together).", min=0,
        max=5, tunable=True),
    opt("body_max_width_m", "float", 0.6, "Widest body.", min=0, max=5, tunable=True),
    opt("leg_pair_m", "float", 0.6, "Two legs closer than this are one person.", min=0,
        max=5, tunable=True),
    opt("max_range_m", "float", 6.0, "People farther than this are not looked for.",
        min=0.1, max=100, tunable=True),
    opt("track_gate_m", "float", 0.5, "A detection this close to a track continues it.",
        min=0.01, max=10, tunable=True),
    opt("track_timeout_s", "float", 1.0, "A track unseen this long is dropped.", min=0.05,
        max=60, tunable=True),
))
"""The people detector's and tracker's settings."""

NAV_LOCALISATION_SECTIONS = (LOCALISATION, PEOPLE)
NAV_LOCALISATION_ORDERS = (
    Order(("localisation.min_particles", "localisation.max_particles"), strict=False),
    Order(("people.min_points_floor", "people.min_points"), strict=False),
    Order(("people.leg_min_width_m", "people.leg_max_width_m")),
    Order(("people.body_min_width_m", "people.body_max_width_m")),
)


def _d(section: Section, key: str) -> Any:
    return section.by_key[key].default


@dataclass(frozen=True, slots=True)
class LocalisationConfig:
    """The ``localisation`` section, read once per settings change."""

    initial_pose: str = _d(LOCALISATION, "initial_pose")
    initial_x_m: float = _d(LOCALISATION, "initial_x_m")
    initial_y_m: float = _d(LOCALISATION, "initial_y_m")
    initial_heading_rad: float = 0.0
    initial_sigma_m: float = _d(LOCALISATION, "initial_sigma_m")
    initial_sigma_rad: float = math.radians(_d(LOCALISATION, "initial_sigma_deg"))
    min_particles: int = _d(LOCALISATION, "min_particles")
    max_particles: int = _d(LOCALISATION, "max_particles")
    global_particles: int = _d(LOCALISATION, "global_particles")
    kld_err: float = _d(LOCALISATION, "kld_err")
    kld_z: float = _d(LOCALISATION, "kld_z")
    alphas: tuple[float, float, float, float] = (0.2, 0.2, 0.2, 0.2)
    max_beams: int = _d(LOCALISATION, "max_beams")
    beam_combine: str = _d(LOCALISATION, "beam_combine")
    z_hit: float = _d(LOCALISATION, "z_hit")
    z_rand: float = _d(LOCALISATION, "z_rand")
    sigma_hit_m: float = _d(LOCALISATION, "sigma_hit_m")
    likelihood_max_dist_m: float = _d(LOCALISATION, "likelihood_max_dist_m")
    laser_max_range_m: float = _d(LOCALISATION, "laser_max_range_m")
    update_min_d_m: float = _d(LOCALISATION, "update_min_d_m")
    update_min_a_rad: float = math.radians(_d(LOCALISATION, "update_min_a_deg"))
    alpha_slow: float = _d(LOCALISATION, "alpha_slow")
    alpha_fast: float = _d(LOCALISATION, "alpha_fast")
    seed: int = _d(LOCALISATION, "seed")
    publish_hz: float = _d(LOCALISATION, "publish_hz")
    diverged_s: float = _d(LOCALISATION, "diverged_s")
    max_spread_m: float = _d(LOCALISATION, "max_spread_m")
    max_spread_rad: float = math.radians(_d(LOCALISATION, "max_spread_deg"))
    match_distance_m: float = _d(LOCALISATION, "match_distance_m")
    min_match_fraction: float = _d(LOCALISATION, "min_match_fraction")
    lidar_lost_max_s: float = _d(LOCALISATION, "lidar_lost_max_s")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> LocalisationConfig:
        s = settings.section("localisation")
        return cls(
            initial_pose=s["initial_pose"], initial_x_m=s["initial_x_m"],
            initial_y_m=s["initial_y_m"],
            initial_heading_rad=math.radians(s["initial_heading_deg"]),
            initial_sigma_m=s["initial_sigma_m"],
            initial_sigma_rad=math.radians(s["initial_sigma_deg"]),
            min_particles=s["min_particles"], max_particles=s["max_particles"],
            global_particles=s["global_particles"], kld_err=s["kld_err"], kld_z=s["kld_z"],
            alphas=(s["alpha1"], s["alpha2"], s["alpha3"], s["alpha4"]),
            max_beams=s["max_beams"], beam_combine=s["beam_combine"], z_hit=s["z_hit"],
            z_rand=s["z_rand"],
            sigma_hit_m=s["sigma_hit_m"], likelihood_max_dist_m=s["likelihood_max_dist_m"],
            laser_max_range_m=s["laser_max_range_m"], update_min_d_m=s["update_min_d_m"],
            update_min_a_rad=math.radians(s["update_min_a_deg"]),
            alpha_slow=s["alpha_slow"], alpha_fast=s["alpha_fast"], seed=s["seed"],
            publish_hz=s["publish_hz"], diverged_s=s["diverged_s"],
            max_spread_m=s["max_spread_m"], max_spread_rad=math.radians(s["max_spread_deg"]),
            match_distance_m=s["match_distance_m"],
            min_match_fraction=s["min_match_fraction"],
            lidar_lost_max_s=s["lidar_lost_max_s"],
        )


@dataclass(frozen=True, slots=True)
class PeopleConfig:
    """The ``people`` section, read once per settings change."""

    cluster_gap_m: float = _d(PEOPLE, "cluster_gap_m")
    min_points: int = _d(PEOPLE, "min_points")
    min_points_floor: int = _d(PEOPLE, "min_points_floor")
    point_fill: float = _d(PEOPLE, "point_fill")
    unexplained_m: float = _d(PEOPLE, "unexplained_m")
    leg_min_width_m: float = _d(PEOPLE, "leg_min_width_m")
    leg_max_width_m: float = _d(PEOPLE, "leg_max_width_m")
    body_min_width_m: float = _d(PEOPLE, "body_min_width_m")
    body_max_width_m: float = _d(PEOPLE, "body_max_width_m")
    leg_pair_m: float = _d(PEOPLE, "leg_pair_m")
    max_range_m: float = _d(PEOPLE, "max_range_m")
    track_gate_m: float = _d(PEOPLE, "track_gate_m")
    track_timeout_s: float = _d(PEOPLE, "track_timeout_s")

    @classmethod
    def from_settings(cls, settings: SettingsView) -> PeopleConfig:
        s = settings.section("people")
        return cls(**{key: s[key] for key in PEOPLE.by_key})
