"""The vacuum profile's own config section: ``vacuum`` (cleaning, battery check, schedule)."""

from __future__ import annotations

from hal.options import Option, Section

VACUUM = Section(
    "vacuum",
    "The robot vacuum (seed ir-docking-flowcharts.md): cleaning and its schedule.",
    (
        Option("clean_mps", "float", 0.2, "Speed while cleaning.", min=0.02, max=1.0,
               tunable=True),
        Option("battery_check_s", "float", 10.0,
               "The seed's periodic battery check while cleaning, every this long.",
               min=0.5, max=3600, tunable=True),
        Option("wall_follow_s", "float", 15.0,
               "Follow a wall met on the right this long before bouncing on again.",
               min=0, max=3600, tunable=True),
        Option("standby_s", "float", 60.0,
               "In standby on the dock, the next clean starts after this long.", min=0,
               max=604800, tunable=True),
        Option("autostart", "bool", True, "Start cleaning once booted."),
    ),
)
