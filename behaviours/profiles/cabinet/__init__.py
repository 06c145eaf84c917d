"""The cabinet robot (seed cabinet-robot-task-phases.md): fits its scan, visits cabinets by graph.

Its site map, task list, node graph, states and step tasks; the formats and choices are in
``docs/cabinet.md``.
"""

from __future__ import annotations

from behaviours.profile import ProfileSpec
from behaviours.profiles.cabinet.config import CABINET
from behaviours.profiles.cabinet.config_files import cabinet_file_problems
from behaviours.profiles.cabinet.ctl_commands import COMMANDS
from behaviours.profiles.cabinet.profile import CabinetProfile

SPEC = ProfileSpec(
    CabinetProfile,
    "reads its JSON map and task list, fits its LiDAR scan to the map from an unknown pose, "
    "then visits each cabinet over a node graph (breaking blocked links, resetting them), "
    "and performs the task's action in front of it",
    sections=(CABINET,),
    file_checks=(cabinet_file_problems,),
    commands=COMMANDS,
)
