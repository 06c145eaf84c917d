"""The ``localisation`` and ``people`` config sections, declared by the settings read from them.

Values are the RelayBot seed's where it gives one (section 9: 10 Hz localisation, 10 points
and 0.3 m for a person); the particle filter's are Nav2 AMCL's defaults (``nav2_params.yaml``:
alpha1-4 0.2, 60 beams, z_hit/z_rand 0.5, sigma_hit 0.2, 500-2000 particles, kld 0.05/0.99,
update_min_d 0.25 m / update_min_a 0.2 rad), except the recovery rates, which Nav2 leaves at
0 (off) and its documentation suggests 0.001 / 0.1 for: the issue asks for the recovery on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hal.options import Order, load, section_of, setting
from hal.settings import SettingsView


@dataclass(frozen=True, slots=True)
class LocalisationConfig:
    """The particle filter's settings (Nav2 AMCL's names where it has one), read once per
    settings change."""

    initial_pose: str = setting(
        "config", "Where the filter starts: config (initial_*), store (the last saved pose, "
        "else config), global (spread over the map's free space).",
        choices=("config", "store", "global"))
    initial_x_m: float = setting(0.0, "Start position x in the map frame.", min=-1e4, max=1e4)
    initial_y_m: float = setting(0.0, "Start position y in the map frame.", min=-1e4, max=1e4)
    initial_heading_deg: float = setting(0.0, "Start heading, counter-clockwise from +x.",
                                         min=-360, max=360)
    initial_sigma_m: float = setting(0.5, "Spread of the start position (AMCL: 0.5 m).",
                                     min=0, max=100)
    initial_sigma_deg: float = setting(15.0, "Spread of the start heading (AMCL: pi/12).",
                                       min=0, max=180)
    min_particles: int = setting(500, "Fewest particles (KLD sampling).", min=10, max=100000)
    max_particles: int = setting(2000, "Most particles (KLD sampling).", min=10, max=100000)
    global_particles: int = setting(
        20000, "Poses the first scan weighs after a global start (then max_particles).",
        min=10, max=1000000)
    kld_err: float = setting(0.05, "KLD sampling: largest error of the sample-based posterior.",
                             min=0.001, max=1)
    kld_z: float = setting(0.99, "KLD sampling: probability that the error stays below kld_err.",
                           min=0.5, max=0.9999)
    alpha1: float = setting(0.2, "Rotation noise from rotation (variance factor).",
                            min=0, max=10, tunable=True)
    alpha2: float = setting(0.2, "Rotation noise from translation.", min=0, max=10,
                            tunable=True)
    alpha3: float = setting(0.2, "Translation noise from translation.", min=0, max=10,
                            tunable=True)
    alpha4: float = setting(0.2, "Translation noise from rotation.", min=0, max=10,
                            tunable=True)
    max_beams: int = setting(60, "Beams of a scan the likelihood field weighs.", min=4,
                             max=2000)
    beam_combine: str = setting(
        "product",
        "product: the scan's likelihood (sharp); cube_sum: Nav2's 1 + sum(pz^3) (flat).",
        choices=("product", "cube_sum"))
    z_hit: float = setting(0.5, "Weight of the hit (Gaussian) part of the beam model.",
                           min=0, max=1, tunable=True)
    z_rand: float = setting(0.5, "Weight of the random part of the beam model.", min=0, max=1,
                            tunable=True)
    sigma_hit_m: float = setting(0.2, "Std of a hit's distance to the nearest obstacle.",
                                 min=0.001, max=5)
    likelihood_max_dist_m: float = setting(2.0, "Distance field cap (AMCL: 2 m).", min=0.05,
                                           max=50)
    laser_max_range_m: float = setting(12.0, "Longer beams are not weighed (LD19: 12 m).",
                                       min=0.1, max=100)
    update_min_d_m: float = setting(0.25, "Travel before a filter update.", min=0, max=10,
                                    tunable=True)
    update_min_a_deg: float = setting(11.5, "Turn before a filter update (AMCL: 0.2 rad).",
                                      min=0, max=180, tunable=True)
    alpha_slow: float = setting(0.001, "Augmented MCL: slow average of the likelihood.",
                                min=0, max=1)
    alpha_fast: float = setting(0.1, "Augmented MCL: fast average (0 and 0: no recovery).",
                                min=0, max=1)
    seed: int = setting(1, "Random seed of the filter (same seed, same poses).", min=0)
    publish_hz: float = setting(
        20.0, "Fused pose rate (seed: >= 10 Hz; 20 keeps every 1 s window at 10 or more).",
        min=10, max=200)
    diverged_s: float = setting(
        2.0, "Spread or scan match past its limit for this long: diverged.", min=0.1, max=600,
        tunable=True)
    max_spread_m: float = setting(0.5, "Position spread (std) above which it is lost.",
                                  min=0.01, max=100, tunable=True)
    max_spread_deg: float = setting(20.0, "Heading spread (std) above which it is lost.",
                                    min=0.1, max=180, tunable=True)
    match_distance_m: float = setting(0.15, "A beam within this of an obstacle matches.",
                                      min=0.01, max=5, tunable=True)
    min_match_fraction: float = setting(
        0.7, "Fewer matching beams than this at the estimate: lost (a person close by hides "
        "about 5 %; a 1 m kidnap in a room leaves about 55 %).", min=0, max=1, tunable=True)
    lidar_lost_max_s: float = setting(
        30.0, "Odometry alone for at most this long, then an error (seed: 30 s).", min=0,
        max=3600, tunable=True)
    relocalise: str = setting(
        "global", "A diverged filter while driving: global (stop, find the scan anywhere on "
        "the map, turn on the spot until the filter agrees, then go on) or off (the goal "
        "fails as diverged).", choices=("global", "off"), tunable=True)
    relocalise_limit_s: float = setting(
        30.0, "A global relocalisation gives up after this long.", min=1, max=3600,
        tunable=True)

    @property
    def initial_heading_rad(self) -> float:
        return math.radians(self.initial_heading_deg)

    @property
    def initial_sigma_rad(self) -> float:
        return math.radians(self.initial_sigma_deg)

    @property
    def alphas(self) -> tuple[float, float, float, float]:
        return self.alpha1, self.alpha2, self.alpha3, self.alpha4

    @property
    def update_min_a_rad(self) -> float:
        return math.radians(self.update_min_a_deg)

    @property
    def max_spread_rad(self) -> float:
        return math.radians(self.max_spread_deg)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> LocalisationConfig:
        return load(cls, settings.section(LOCALISATION.name))


@dataclass(frozen=True, slots=True)
class PeopleConfig:
    """The people detector's and tracker's settings, read once per settings change."""

    cluster_gap_m: float = setting(
        0.3, "Neighbouring points closer than this: one cluster (seed: 0.3 m).", min=0.01,
        max=5, tunable=True)
    min_points: int = setting(
        10, "Points a close person needs (seed: 10); farther, fewer (see point_fill).",
        min=1, max=1000, tunable=True)
    min_points_floor: int = setting(3, "Never fewer points than this, at any range.", min=1,
                                    max=1000, tunable=True)
    point_fill: float = setting(
        0.5, "A cluster needs this fraction of the points its width spans at its range.",
        min=0, max=1, tunable=True)
    unexplained_m: float = setting(
        0.2, "A point this far from every occupied map cell is not the map's.", min=0.01,
        max=5, tunable=True)
    leg_min_width_m: float = setting(0.05, "Narrowest leg.", min=0, max=5, tunable=True)
    leg_max_width_m: float = setting(0.25, "Widest leg.", min=0, max=5, tunable=True)
    body_min_width_m: float = setting(0.3, "Narrowest body (or two legs together).", min=0,
                                      max=5, tunable=True)
    body_max_width_m: float = setting(0.6, "Widest body.", min=0, max=5, tunable=True)
    leg_pair_m: float = setting(0.6, "Two legs closer than this are one person.", min=0,
                                max=5, tunable=True)
    max_range_m: float = setting(6.0, "People farther than this are not looked for.",
                                 min=0.1, max=100, tunable=True)
    track_gate_m: float = setting(0.5, "A detection this close to a track continues it.",
                                  min=0.01, max=10, tunable=True)
    track_timeout_s: float = setting(1.0, "A track unseen this long is dropped.", min=0.05,
                                     max=60, tunable=True)

    @classmethod
    def from_settings(cls, settings: SettingsView) -> PeopleConfig:
        return load(cls, settings.section(PEOPLE.name))


LOCALISATION = section_of(LocalisationConfig, "localisation",
                          "Monte Carlo localisation on the map (behaviours.nav).")
PEOPLE = section_of(PeopleConfig, "people",
                    "People in the LiDAR scan: clusters the map does not explain.")

NAV_LOCALISATION_SECTIONS = (LOCALISATION, PEOPLE)
NAV_LOCALISATION_ORDERS = (
    Order(("localisation.min_particles", "localisation.max_particles"), strict=False),
    Order(("people.min_points_floor", "people.min_points"), strict=False),
    Order(("people.leg_min_width_m", "people.leg_max_width_m")),
    Order(("people.body_min_width_m", "people.body_max_width_m")),
)
