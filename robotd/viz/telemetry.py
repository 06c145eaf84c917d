"""One robot's ``hal.telemetry.Telemetry`` on a Foxglove context: topics, channels, decimation.

A channel is made the first time its topic is published. Each call first asks the channel
whether anything listens (a connected viewer that subscribed, or a recording): when nothing
does, no message is built. Heavy kinds are decimated on the event loop's clock (an image or
a particle cloud at most every ``_PERIOD_S``); every message is logged with ``log_time`` =
the loop's time in nanoseconds, so a simulator's recording is on its virtual clock. With
``hold`` (a recording and no live viewer) JSON values wait for ``flush``, each at its call's
time: made in a batch they cost a fraction of what they do one by one between a simulation's
steps.

With several robots in one view (``robotd sim`` of a multi-robot scenario) each robot's topics
sit under ``/<name>/`` and its frames under ``<name>/`` (``map`` is shared).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import foxglove
import numpy as np
import numpy.typing as npt
import orjson
import structlog
from foxglove.channels import (
    CompressedImageChannel,
    FrameTransformChannel,
    GridChannel,
    LaserScanChannel,
    PoseInFrameChannel,
    PosesInFrameChannel,
    SceneUpdateChannel,
)

from hal.readings import LidarScan
from hal.telemetry import Image, Pose2D
from robotd.viz import messages as fm

log = structlog.get_logger(__name__)

# A node graph changes rarely and each change (a broken link) matters: every one is sent.
# The camera at 1 Hz: a simulated camera renders its whole frame only for an image (the tracker
# reads 8 rows), so at 2 Hz the images alone were ~6 % of a laundry run.
_PERIOD_S = {"image": 1.0, "poses": 0.5, "grid": 5.0, "graph": 0.0, "path": 0.5,
             "sample": 0.1}
"""The shortest interval between two messages of a kind on one topic (virtual seconds)."""
_MAX_PARTICLES = 500
_HOLD_MAX = 256
"""JSON values held at most (``hold``) before they are sent anyway."""
_SHARED_FRAMES = ("map",)


_JSON_OPTIONS = orjson.OPT_NON_STR_KEYS | orjson.OPT_SERIALIZE_NUMPY


def json_bytes(value: Any) -> bytes:
    """``value`` as compact JSON; what JSON has no type for (a path, an enum) as its ``str``.

    orjson rather than the standard library: inside a running simulation (the caches full of
    the world's data) one message cost ~29 us with ``json.dumps`` against ~9 us, and a
    recording sends thousands. It also writes NaN as ``null`` (the standard library writes
    ``NaN``, which is not JSON), and numpy's scalars and arrays as numbers.
    """
    return orjson.dumps(value, default=str, option=_JSON_OPTIONS)


def loop_time_ns() -> int:
    """The running event loop's time (virtual in the simulator) in nanoseconds; 0 outside."""
    try:
        return int(asyncio.get_running_loop().time() * 1e9)
    except RuntimeError:
        return 0


class FoxgloveTelemetry:
    """Publishes one robot's calls on ``context``'s channels.

    Args:
        context: the run's Foxglove context (its server and recorder are its sinks).
        prefix: the robot's name when several robots share the context, else "".
        clock_ns: the time messages are logged at (the event loop's, by default).
        periods: shortest intervals (s) by kind that replace ``_PERIOD_S``'s.
        hold: JSON values are held and sent by ``flush`` (a recording with no live viewer):
            each is logged at the time of its call; made in a batch, one costs a fraction of
            what it does between the simulation's steps (whose data fill the caches).
    """

    def __init__(self, context: foxglove.Context, prefix: str = "", *,
                 clock_ns: Callable[[], int] = loop_time_ns,
                 periods: Mapping[str, float] | None = None, hold: bool = False) -> None:
        self.context = context
        self.prefix = prefix
        self.clock_ns = clock_ns
        chosen = {**_PERIOD_S, **(periods or {})}
        self._period_ns = {kind: int(period_s * 1e9) for kind, period_s in chosen.items()}
        self._channels: dict[str, Any] = {}
        self._next_ns: dict[str, int] = {}
        self.hold = hold
        self._held: list[tuple[Any, str, int, dict[str, Any]]] = []
        self.published = 0
        self.failed = 0

    @property
    def enabled(self) -> bool:
        return True

    # --- the Telemetry port ---------------------------------------------------------------
    def pose(self, topic: str, pose: Pose2D, *, frame: str = "map",
             child_frame: str | None = None, t_ns: int | None = None) -> None:
        """``t_ns``: the instant the pose was taken, when not now (a batch of samples)."""
        if t_ns is None:
            t_ns = self.clock_ns()
        self._log(topic, PoseInFrameChannel, t_ns,
                  lambda: fm.pose_in_frame(t_ns, pose, self.frame(frame)))
        if child_frame is not None:
            self._log("tf", FrameTransformChannel, t_ns,
                      lambda: fm.transform(t_ns, pose, self.frame(frame), self.frame(child_frame)))

    def poses(self, topic: str, poses: npt.NDArray[np.float64] | Sequence[Pose2D], *,
              frame: str = "map") -> None:
        t_ns = self.clock_ns()
        if self._due(topic, "poses", t_ns):
            self._log(topic, PosesInFrameChannel, t_ns,
                      lambda: fm.poses_in_frame(t_ns, poses, self.frame(frame), _MAX_PARTICLES))

    def scan(self, topic: str, scan: LidarScan, *, frame: str = "base_link") -> None:
        t_ns = self.clock_ns()
        self._log(topic, LaserScanChannel, t_ns, lambda: fm.laser_scan(t_ns, scan,
                                                                       self.frame(frame)))

    def path(self, topic: str, points: Sequence[tuple[float, float]], *,
             frame: str = "map") -> None:
        t_ns = self.clock_ns()
        if self._due(topic, "path", t_ns):
            self._log(topic, SceneUpdateChannel, t_ns,
                      lambda: fm.path_scene(t_ns, topic, points, self.frame(frame)))

    def grid(self, topic: str, occupied: npt.NDArray[np.bool_], resolution_m: float,
             origin_xy_m: tuple[float, float], *, frame: str = "map") -> None:
        t_ns = self.clock_ns()
        if self._due(topic, "grid", t_ns):
            self._log(topic, GridChannel, t_ns, lambda: fm.occupancy_grid(
                t_ns, occupied, resolution_m, origin_xy_m, self.frame(frame)))

    def graph(self, topic: str, nodes: Mapping[str, tuple[float, float]],
              edges: Sequence[tuple[str, str]], *, frame: str = "map",
              warn: bool = False) -> None:
        t_ns = self.clock_ns()
        if self._due(topic, "graph", t_ns):
            self._log(topic, SceneUpdateChannel, t_ns,
                      lambda: fm.graph_scene(t_ns, topic, nodes, edges, self.frame(frame),
                                                     warn=warn))

    def image(self, topic: str, image: Image, *, marks: Sequence[tuple[int, int]] = ()) -> None:
        t_ns = self.clock_ns()
        if self._due(topic, "image", t_ns):
            # A function is called here only: a frame is drawn only for the images sent.
            self._log(topic, CompressedImageChannel, t_ns, lambda: fm.jpeg_image(
                t_ns, image() if callable(image) else image, marks, self.frame("camera")))

    def sample(self, topic: str, /, **fields: Any) -> None:
        if self._due(topic, "sample", self.clock_ns()):
            self.values(topic, **fields)

    def values(self, topic: str, /, **fields: Any) -> None:
        t_ns = self.clock_ns()
        channel = self._channel(topic, None)
        if channel is None or not channel.has_sinks():
            return
        if self.hold:
            self._held.append((channel, topic, t_ns, fields))
            if len(self._held) >= _HOLD_MAX:
                self.flush()
            return
        self._send(channel, topic, t_ns, fields)

    def flush(self) -> None:
        """Send the JSON values held (``hold``), in the order they came."""
        held, self._held = self._held, []
        for channel, topic, t_ns, fields in held:
            self._send(channel, topic, t_ns, fields)

    # --- helpers ----------------------------------------------------------------------------
    def topic(self, name: str) -> str:
        """The full topic of a short name: ``/scan`` or ``/<robot>/scan``."""
        return f"/{self.prefix}/{name}" if self.prefix else f"/{name}"

    def frame(self, name: str) -> str:
        if not self.prefix or name in _SHARED_FRAMES:
            return name
        return f"{self.prefix}/{name}"

    def _due(self, topic: str, kind: str, t_ns: int) -> bool:
        next_ns = self._next_ns.get(topic)
        if next_ns is not None and t_ns < next_ns:
            return False
        self._next_ns[topic] = t_ns + self._period_ns[kind]
        return True

    def _channel(self, topic: str, kind: Any) -> Any:
        channel = self._channels.get(topic)
        if channel is None:
            full = self.topic(topic)
            try:
                if kind is None:  # plain JSON: an open object schema, named for the topic
                    title = "robotd." + topic.replace("/", ".")
                    channel = foxglove.Channel(full, schema={"type": "object", "title": title},
                                               context=self.context)
                else:
                    channel = kind(full, context=self.context)
            except Exception as exc:  # e.g. one topic published with two kinds
                self._failed(topic, exc)
                return None
            self._channels[topic] = channel
        return channel

    def _log(self, topic: str, kind: Any, t_ns: int, build: Callable[[], Any]) -> None:
        channel = self._channel(topic, kind)
        if channel is None or not channel.has_sinks():
            return
        try:
            message = build()
            if message is not None:
                channel.log(message, log_time=t_ns)
                self.published += 1
        except Exception as exc:  # bad data is counted and named, never raised to the robot
            self._failed(topic, exc)

    def _send(self, channel: Any, topic: str, t_ns: int, fields: dict[str, Any]) -> None:
        try:
            channel.log(json_bytes({"t_s": t_ns / 1e9, **fields}), log_time=t_ns)
            self.published += 1
        except Exception as exc:  # a viewer's trouble must not reach the robot
            self._failed(topic, exc)

    def _failed(self, topic: str, exc: Exception) -> None:
        self.failed += 1
        if self.failed == 1 or self.failed % 100 == 0:
            log.warning("viz.publish_failed", topic=self.topic(topic), error=repr(exc),
                        failed=self.failed)
