"""The laundry robot's mission states and triggers (seed 000: the request lifecycle the robot
lives), as constants beside the tables that use them.

The robot follows the line to a customer's room (``to_room``), waits there for the load or the
hand-over (``at_room``), follows it back (``to_base``), waits behind the robot ahead at base
(``queued``) and waits at the base beacon (``at_base``). The waiting states have no task: the
fleet server's next directive (or the local route) moves the robot on.
"""

from __future__ import annotations

from typing import Any, Final

from behaviours.machine_tables import RootState


class LaundryState:
    """The mission's leaves as dotted paths, as logs, events and the control socket show them."""

    TO_ROOM: Final = "mission.to_room"
    AT_ROOM: Final = "mission.at_room"
    TO_BASE: Final = "mission.to_base"
    QUEUED: Final = "mission.queued"
    """At base behind the robot ahead, pulling up as the queue moves (``base_queue``)."""
    AT_BASE: Final = "mission.at_base"


class LaundryTrigger:
    """The triggers of the mission's transitions (the core's, e.g. ``fault``, are the core's)."""

    GO_ROOM: Final = "go_room"
    GO_BASE: Final = "go_base"
    ARRIVED_ROOM: Final = "arrived_room"
    QUEUED: Final = "queued"
    ARRIVED_BASE: Final = "arrived_base"


S, T = LaundryState, LaundryTrigger
MISSION_STATES = ["to_room", "at_room", "to_base", "queued", "at_base"]
"""The leaves under ``mission``, relative (``transitions`` nests them)."""
FOLLOWING = (S.TO_ROOM, S.TO_BASE, S.QUEUED)
"""The states in which the robot follows the line."""
WAITING = (S.AT_ROOM, S.AT_BASE)
"""The states that wait for a directive and have no task."""

_ANYWHERE = [RootState.IDLE, S.AT_ROOM, S.AT_BASE, S.TO_ROOM, S.TO_BASE, S.QUEUED]
MISSION_TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": T.GO_ROOM, "source": [s for s in _ANYWHERE if s != S.TO_ROOM],
     "dest": S.TO_ROOM},
    {"trigger": T.GO_BASE, "source": [s for s in _ANYWHERE if s not in (S.TO_BASE, S.QUEUED)],
     "dest": S.TO_BASE},
    {"trigger": T.ARRIVED_ROOM, "source": S.TO_ROOM, "dest": S.AT_ROOM},
    {"trigger": T.QUEUED, "source": S.TO_BASE, "dest": S.QUEUED},
    {"trigger": T.ARRIVED_BASE, "source": [S.TO_BASE, S.QUEUED], "dest": S.AT_BASE},
]
