"""The docking behaviour's options in the ``docking`` section, and ``DockingConfig`` read once.

The section also holds the dock IR receivers' options (``drivers/dock_ir/config.py``);
``robotd/config/sections.py`` puts both together.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from behaviours.docking.tables import WAIT_EMPTY_MAX_S
from hal.options import Option, Order
from hal.settings import SettingsView

ROLES = ("far_left", "far_right", "front_left", "front_right", "centre", "force_field")
"""The seed's beams, as a robot facing the dock names them."""

DEFAULT_BEAM_ROLES = {"far_left": "far_left", "far_right": "far_right",
                      "front_left": "red_buoy", "front_right": "green_buoy",
                      "centre": "centre", "force_field": "force_field"}
"""Seed beam -> the name ``docking.ir_codes`` gives its code (the OI home base's buoys for
the two front beams)."""

DOCKING_OPTIONS: tuple[Option, ...] = (
    Option("battery_threshold_pct", "float", 20.0, "Go to the dock below this charge.",
           min=0, max=100, tunable=True),
    Option("max_retries", "int", 3,
           "Failed attempts before the fallback to wall following (the seed's 3).",
           min=1, max=20, tunable=True),
    Option("max_fallbacks", "int", 2,
           "Fallbacks to wall following before giving up to recovery.", min=0, max=20,
           tunable=True),
    Option("beam_roles", "table", DEFAULT_BEAM_ROLES,
           "Seed beam (far_left, far_right, front_left, front_right, centre, force_field) -> "
           "beam name in docking.ir_codes."),
    Option("search_mps", "float", 0.25, "Speed while wall following to find the dock.",
           min=0.02, max=1.0, tunable=True),
    Option("approach_mps", "float", 0.2, "Speed while approaching on the beams.",
           min=0.02, max=1.0, tunable=True),
    Option("dock_mps", "float", 0.08, "The slow forward onto the contacts.", min=0.01,
           max=0.5, tunable=True),
    Option("turn_dps", "float", 60.0, "Turning rate in place.", min=5, max=360, tunable=True),
    Option("micro_turn_deg", "float", 4.0, "One micro turn (approach and align).", min=0.5,
           max=30, tunable=True),
    Option("side_turn_deg", "float", 45.0,
           "Left/right approach: how far to turn across the beams.", min=10, max=90,
           tunable=True),
    Option("balance_ratio", "float", 0.3,
           "L ~ R when |L - R| <= this x max(L, R) (front receivers' strength).", min=0.0,
           max=1.0, tunable=True),
    Option("min_signal", "int", 20, "Front strength below this counts as no signal (0-1023).",
           min=0, max=1023, tunable=True),
    Option("align_strength", "int", 120,
           "Close in until the front pair reads this strength (0-1023), then align there "
           "(unsaturated: the compare still tells left from right).", min=1, max=1000,
           tunable=True),
    Option("signal_lost_s", "float", 5.0, "No dock beam this long while docking: signal lost.",
           min=0.2, max=60, tunable=True),
    Option("ir_stale_s", "float", 1.5, "No dock IR reading this long: the device is lost.",
           min=0.2, max=60, tunable=True),
    Option("contact_min_mv", "int", 14_000, "Lowest contact voltage that counts as docked.",
           min=0, max=30_000, tunable=True),
    Option("contact_max_mv", "int", 19_000, "Highest contact voltage that counts as docked.",
           min=0, max=30_000, tunable=True),
    Option("contact_hold_s", "float", 0.5,
           "The voltage must stay within its limits this long.", min=0.0, max=10, tunable=True),
    Option("contact_travel_m", "float", 1.0,
           "Slow forward at most this far (from the end of alignment) before contact failed.",
           min=0.05, max=3, tunable=True),
    Option("back_off_m", "float", 0.25, "Back off this far before trying again.", min=0.02,
           max=2, tunable=True),
    Option("empty_min_s", "float", 10.0, "Station suction runs at least this long.", min=0,
           max=WAIT_EMPTY_MAX_S, tunable=True),
    Option("empty_max_s", "float", 30.0,
           "... and at most this long (the seed's 10-30 s; wait_empty's state timeout, 30 s, "
           "is the hard limit).", min=0.1, max=WAIT_EMPTY_MAX_S, tunable=True),
    Option("bin_full_pct", "float", 60.0, "Empty the bin at the station from this level.",
           min=0, max=100, tunable=True),
    Option("bin_empty_pct", "float", 5.0, "The bin counts as empty at or below this level.",
           min=0, max=100, tunable=True),
    Option("charge_full_pct", "float", 95.0, "Charging is done at this charge.", min=1,
           max=100, tunable=True),
    Option("undock_distance_m", "float", 0.4, "How far to back out of the dock.", min=0.05,
           max=3, tunable=True),
    Option("bin_door_open_deg", "int", 90, "Bin door servo angle, open.", min=0, max=180),
    Option("bin_door_closed_deg", "int", 0, "Bin door servo angle, closed.", min=0, max=180),
)
"""The docking behaviour's options (``docking`` section)."""

DOCKING_ORDERS: tuple[Order, ...] = (
    Order(("docking.contact_min_mv", "docking.contact_max_mv")),
    Order(("docking.empty_min_s", "docking.empty_max_s"), strict=False),
    Order(("docking.bin_empty_pct", "docking.bin_full_pct")),
)


@dataclass(frozen=True, slots=True)
class DockingConfig:
    """The ``docking`` options a docking behaviour reads, taken once per phase."""

    battery_threshold_pct: float = 20.0
    beam_roles: dict[str, str] = field(default_factory=lambda: dict(DEFAULT_BEAM_ROLES))
    search_mps: float = 0.25
    approach_mps: float = 0.2
    dock_mps: float = 0.08
    turn_dps: float = 60.0
    micro_turn_deg: float = 4.0
    side_turn_deg: float = 45.0
    balance_ratio: float = 0.3
    min_signal: int = 20
    align_strength: int = 120
    signal_lost_s: float = 5.0
    ir_stale_s: float = 1.5
    contact_min_mv: int = 14_000
    contact_max_mv: int = 19_000
    contact_hold_s: float = 0.5
    contact_travel_m: float = 1.0
    back_off_m: float = 0.25
    empty_min_s: float = 10.0
    empty_max_s: float = 30.0
    bin_full_pct: float = 60.0
    bin_empty_pct: float = 5.0
    charge_full_pct: float = 95.0
    undock_distance_m: float = 0.4
    bin_door_open_deg: int = 90
    bin_door_closed_deg: int = 0

    @classmethod
    def from_settings(cls, settings: SettingsView) -> DockingConfig:
        section: dict[str, Any] = settings.section("docking")
        values = {name: section[name] for name in cls.__slots__ if name in section}
        roles = dict(DEFAULT_BEAM_ROLES)
        roles.update({str(k): str(v) for k, v in dict(values.pop("beam_roles", {})).items()})
        return cls(beam_roles=roles, **values)

    def beam(self, role: str) -> str:
        """The beam name the decoder gives the seed's ``role``."""
        return self.beam_roles.get(role, role)

    def contact_ok(self, mv: int) -> bool:
        """Within the limits that count as docked (never outside them)."""
        return self.contact_min_mv <= mv <= self.contact_max_mv
