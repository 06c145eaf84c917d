"""What behaviours show a live viewer: a port with typed publish calls, a no-op by default.

Behaviours (localisation, the path follower, the line follower, docking, beacons, any robot's
own mission) publish what they have through ``Telemetry``; they never see the viewer. The
daemon's adapter (``robotd/viz``) turns the calls into Foxglove messages on the event loop's
time, decimates what is heavy (images, particle clouds, grids) and skips everything when no
viewer or recording is on. ``NULL_TELEMETRY`` is what a robot gets when viz is off: each
call returns at once; a caller that has to *build* something costly first asks ``enabled``.

Frames: ``map`` is the world's frame; ``base_link`` the robot's (x forward, y left), placed
in ``map`` by the estimated pose. Topics are short names (``scan``, ``path``,
``beacons``); the adapter puts them under the robot's name when several robots share a view.

A new robot publishes its own things with one line each, e.g.
``ctx.telemetry.graph("nodes", nodes, edges)`` or ``ctx.telemetry.values("box", open=True)``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from hal.readings import LidarScan

__all__ = ["NULL_TELEMETRY", "Image", "NullTelemetry", "Pose2D", "Telemetry"]

Pose2D = tuple[float, float, float]
"""x_m, y_m, heading_rad in the map frame."""
Image = npt.NDArray[np.uint8] | Callable[[], npt.NDArray[np.uint8]]
"""An image, or a function that draws it (called only if the image is published)."""


@runtime_checkable
class Telemetry(Protocol):
    """Typed publishing for the live view and recordings; every call is cheap or a no-op."""

    @property
    def enabled(self) -> bool:
        """False when nothing is listening: skip building what would be published."""
        ...

    def pose(self, topic: str, pose: Pose2D, *, frame: str = "map",
             child_frame: str | None = None) -> None:
        """A pose (``child_frame`` given: also the transform ``frame -> child_frame``)."""
        ...

    def poses(self, topic: str, poses: npt.NDArray[np.float64] | Sequence[Pose2D], *,
              frame: str = "map") -> None:
        """Many poses at once (a particle cloud), an (n, 3) array of x, y, heading."""
        ...

    def scan(self, topic: str, scan: LidarScan, *, frame: str = "base_link") -> None:
        """A LiDAR scan in the robot's frame."""
        ...

    def path(self, topic: str, points: Sequence[tuple[float, float]], *,
             frame: str = "map") -> None:
        """A polyline (a planned path, a route) in ``frame``."""
        ...

    def grid(self, topic: str, occupied: npt.NDArray[np.bool_], resolution_m: float,
             origin_xy_m: tuple[float, float], *, frame: str = "map") -> None:
        """An occupancy grid (``occupied[row, col]``, row 0 at ``origin_xy_m``'s y)."""
        ...

    def graph(self, topic: str, nodes: Mapping[str, tuple[float, float]],
              edges: Sequence[tuple[str, str]], *, frame: str = "map",
              warn: bool = False) -> None:
        """A node graph (a cabinet robot's stops and the ways between them); ``warn``: its
        edges drawn in red (e.g. broken links)."""
        ...

    def image(self, topic: str, image: Image, *, marks: Sequence[tuple[int, int]] = ()) -> None:
        """A camera frame (grey or BGR), or a function that returns it, called only when the
        image is published (decimated: drawing it may cost); ``marks`` are (column, row)
        pixels drawn on it."""
        ...

    def values(self, topic: str, /, **fields: Any) -> None:
        """Plain data as JSON, every call delivered (a state, an event, a box's state).

        The fields are read when the message is made, which may be up to a second after the
        call (a recording with no live viewer makes them in batches), as ``logging`` formats
        its arguments late: pass values not changed afterwards (numbers, strings, new dicts
        and lists)."""
        ...

    def sample(self, topic: str, /, **fields: Any) -> None:
        """A periodic reading as JSON (the line error each frame, IR beams): the viewer may
        get only some of them (at most 10 a second)."""
        ...


class NullTelemetry:
    """Publishes nothing: what every robot has while viz is off."""

    __slots__ = ()

    @property
    def enabled(self) -> bool:
        return False

    def pose(self, topic: str, pose: Pose2D, *, frame: str = "map",
             child_frame: str | None = None) -> None:
        return None

    def poses(self, topic: str, poses: npt.NDArray[np.float64] | Sequence[Pose2D], *,
              frame: str = "map") -> None:
        return None

    def scan(self, topic: str, scan: LidarScan, *, frame: str = "base_link") -> None:
        return None

    def path(self, topic: str, points: Sequence[tuple[float, float]], *,
             frame: str = "map") -> None:
        return None

    def grid(self, topic: str, occupied: npt.NDArray[np.bool_], resolution_m: float,
             origin_xy_m: tuple[float, float], *, frame: str = "map") -> None:
        return None

    def graph(self, topic: str, nodes: Mapping[str, tuple[float, float]],
              edges: Sequence[tuple[str, str]], *, frame: str = "map",
              warn: bool = False) -> None:
        return None

    def image(self, topic: str, image: Image, *, marks: Sequence[tuple[int, int]] = ()) -> None:
        return None

    def values(self, topic: str, /, **fields: Any) -> None:
        return None

    def sample(self, topic: str, /, **fields: Any) -> None:
        return None


NULL_TELEMETRY: Telemetry = NullTelemetry()
