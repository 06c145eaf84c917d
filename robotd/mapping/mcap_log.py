"""Our own recordings as mapping input: LiDAR scans and wheel odometry from a ``run.mcap``.

The live view's recorder (``robotd/viz``; ``robotd sim --report`` writes ``run.mcap``) logs
Foxglove's protobuf messages: ``/scan`` (``foxglove.LaserScan``: the robot-frame scan, evenly
spaced beams from ``start_angle`` to ``end_angle``, no return as infinity), ``/odom``
(``foxglove.PoseInFrame``: the wheel odometry, at the encoders' rate) and, from the
simulator, ``/truth`` (the true pose). Each scan gets the odometry pose interpolated at its
timestamp (and the true pose, as a CLF log's ``TRUEPOS``). With ``still_only`` (the default)
only scans taken standing are kept, as the live mapping keeps them: odometry moved less than
5 mm and 0.3 deg over the scan and the one before (a recording of a robot mapped stop and go).

The protobuf is read with a small wire-format reader here: the field numbers come from the
schema each channel carries (a ``FileDescriptorSet``), so nothing but the ``mcap`` package is
needed. A message that cannot be decoded is skipped and counted, as a bad CLF line is.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from behaviours.nav.icp import Pose
from behaviours.nav.mapping.scan import Scan, between
from robotd.mapping.clf import ClfLog

SCAN_TOPIC = "/scan"
ODOM_TOPIC = "/odom"
TRUTH_TOPIC = "/truth"
STILL_M = 0.005
STILL_RAD = math.radians(0.3)

Fields = dict[int, list[Any]]


def _varint(data: bytes, i: int) -> tuple[int, int]:
    shift = value = 0
    while True:
        byte = data[i]
        i += 1
        value |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return value, i
        shift += 7
        if shift > 63:
            msg = "varint too long"
            raise ValueError(msg)


def wire_fields(data: bytes) -> Fields:
    """Field number -> its values (ints for varints, bytes for the rest), in order."""
    out: Fields = {}
    i = 0
    while i < len(data):
        key, i = _varint(data, i)
        number, kind = key >> 3, key & 7
        value: Any
        if kind == 0:
            value, i = _varint(data, i)
        elif kind == 1:
            value, i = data[i:i + 8], i + 8
        elif kind == 2:
            length, i = _varint(data, i)
            value, i = data[i:i + length], i + length
        elif kind == 5:
            value, i = data[i:i + 4], i + 4
        else:
            msg = f"wire type {kind} not read"
            raise ValueError(msg)
        if i > len(data):
            msg = "message cut short"
            raise ValueError(msg)
        out.setdefault(number, []).append(value)
    return out


def schema_fields(descriptor_set: bytes) -> dict[str, dict[str, int]]:
    """Message name (``foxglove.LaserScan``) -> field name -> number, from a schema's
    ``FileDescriptorSet`` (file 1; its package 2, messages 4; a message's name 1, fields 2,
    nested 3; a field's name 1, number 3)."""
    out: dict[str, dict[str, int]] = {}

    def message(data: bytes, prefix: str) -> None:
        f = wire_fields(data)
        name = f"{prefix}.{f[1][0].decode()}" if prefix else f[1][0].decode()
        out[name] = {}
        for field in f.get(2, []):
            ff = wire_fields(field)
            out[name][ff[1][0].decode()] = int(ff[3][0])
        for nested in f.get(3, []):
            message(nested, name)

    for file in wire_fields(descriptor_set).get(1, []):
        ff = wire_fields(file)
        package = ff[2][0].decode() if 2 in ff else ""
        for m in ff.get(4, []):
            message(m, package)
    return out


class _Decoder:
    def __init__(self, names: dict[str, dict[str, int]]) -> None:
        self.names = names

    def number(self, message: str, field: str) -> int:
        return self.names[message][field]

    def double(self, f: Fields, message: str, field: str) -> float:
        values = f.get(self.number(message, field))
        return float(struct.unpack("<d", values[-1])[0]) if values else 0.0

    def stamp_s(self, f: Fields, message: str) -> float:
        raw = f.get(self.number(message, "timestamp"))
        if not raw:
            msg = "no timestamp"
            raise ValueError(msg)
        t = wire_fields(raw[-1])
        return float(t.get(1, [0])[-1]) + float(t.get(2, [0])[-1]) * 1e-9

    def pose(self, f: Fields, message: str) -> Pose:
        pose = wire_fields(f[self.number(message, "pose")][-1])
        p = wire_fields(pose.get(self.number("foxglove.Pose", "position"), [b""])[-1])
        q = wire_fields(pose.get(self.number("foxglove.Pose", "orientation"), [b""])[-1])
        x = self.double(p, "foxglove.Vector3", "x")
        y = self.double(p, "foxglove.Vector3", "y")
        qz = self.double(q, "foxglove.Quaternion", "z")
        qw = self.double(q, "foxglove.Quaternion", "w")
        return (x, y, 2.0 * math.atan2(qz, qw))

    def ranges(self, f: Fields) -> np.ndarray[Any, np.dtype[np.float64]]:
        chunks = f.get(self.number("foxglove.LaserScan", "ranges"), [])
        raw = b"".join(chunks)  # packed (one run) or one 8-byte value per entry
        return np.frombuffer(raw, dtype="<f8").astype(np.float64)


def read_mcap(path: str | Path, *, max_range_m: float = 12.0, still_only: bool = True
              ) -> ClfLog:
    """The scans (each with its interpolated odometry) and true poses of a recording."""
    from mcap.reader import NonSeekingReader, make_reader

    out = ClfLog()
    scans: list[tuple[float, np.ndarray[Any, np.dtype[np.float64]], float, float]] = []
    odom: list[tuple[float, Pose]] = []
    truth: list[tuple[float, Pose]] = []
    with Path(path).open("rb") as stream:
        try:
            _read(make_reader(stream), out, scans, odom, truth)
        except Exception:  # no summary at its end (a cut file): read it front to back
            for kept in (scans, odom, truth, out.skipped):
                kept.clear()
            stream.seek(0)
            try:
                _read(NonSeekingReader(stream), out, scans, odom, truth, in_order=False)
            except Exception as exc:  # the mcap reader's own errors: where the file breaks
                out.skipped.append((-1, "the recording cannot be read on from here: "
                                        f"{type(exc).__name__} {exc}".rstrip()))
    scans.sort(key=lambda s: s[0])
    out.scans = list(_with_odometry(scans, odom, max_range_m, still_only))
    stamps = [s.timestamp_s for s in out.scans]
    out.true_poses = [(t, p) for t, p in zip(stamps, _at(truth, stamps), strict=True)
                      if p is not None]
    return out


def _read(reader: Any, out: ClfLog,
          scans: list[tuple[float, np.ndarray[Any, np.dtype[np.float64]], float, float]],
          odom: list[tuple[float, Pose]], truth: list[tuple[float, Pose]], *,
          in_order: bool = True) -> None:
    """Decodes the messages into the lists (``in_order``: by log time, which a reader of a
    cut file cannot do: it would hold everything back until the end it never reaches)."""
    decoders: dict[int, _Decoder] = {}
    for index, (schema, channel, message) in enumerate(reader.iter_messages(
            topics=[SCAN_TOPIC, ODOM_TOPIC, TRUTH_TOPIC], log_time_order=in_order)):
        try:
            if schema is None:
                msg = "no schema"
                raise ValueError(msg)
            dec = decoders.get(schema.id)
            if dec is None:
                dec = decoders[schema.id] = _Decoder(schema_fields(schema.data))
            f = wire_fields(message.data)
            if channel.topic == SCAN_TOPIC:
                t = dec.stamp_s(f, "foxglove.LaserScan")
                scans.append((t, dec.ranges(f),
                              dec.double(f, "foxglove.LaserScan", "start_angle"),
                              dec.double(f, "foxglove.LaserScan", "end_angle")))
            else:
                pose = (t := dec.stamp_s(f, "foxglove.PoseInFrame"),
                        dec.pose(f, "foxglove.PoseInFrame"))
                (odom if channel.topic == ODOM_TOPIC else truth).append(pose)
        except (ValueError, KeyError, IndexError, struct.error) as exc:
            out.skipped.append((index, f"{channel.topic}: {exc}"))


def _with_odometry(scans: list[tuple[float, np.ndarray[Any, np.dtype[np.float64]], float,
                                     float]],
                   odom: list[tuple[float, Pose]], max_range_m: float, still_only: bool
                   ) -> Iterator[Scan]:
    poses = _at(odom, [t for t, *_ in scans])
    before: Pose | None = None
    still_before = False
    for (t, ranges, start, end), pose in zip(scans, poses, strict=True):
        if pose is None:
            continue
        previous, before = before, pose
        if still_only:
            if previous is None:
                continue
            step = between(previous, pose)
            still_now = math.hypot(step[0], step[1]) < STILL_M and abs(step[2]) < STILL_RAD
            still, still_before = still_now and still_before, still_now
            if not still:
                continue
        n = ranges.size
        increment = (end - start) / (n - 1) if n > 1 else 0.0
        clipped = np.where(np.isfinite(ranges), ranges, max_range_m)
        yield Scan(t, clipped, start, increment, max_range_m, pose)


def _at(samples: list[tuple[float, Pose]], stamps: list[float]) -> list[Pose | None]:
    """Each stamp's pose, interpolated between the samples around it (None outside them)."""
    if not samples:
        return [None] * len(stamps)
    samples.sort(key=lambda s: s[0])
    times = np.asarray([t for t, _ in samples])
    xs = np.asarray([p[0] for _, p in samples])
    ys = np.asarray([p[1] for _, p in samples])
    headings = np.unwrap(np.asarray([p[2] for _, p in samples]))
    out: list[Pose | None] = []
    for t in stamps:
        if t < times[0] or t > times[-1]:
            out.append(None)
            continue
        heading = float(np.interp(t, times, headings))
        out.append((float(np.interp(t, times, xs)), float(np.interp(t, times, ys)),
                    math.atan2(math.sin(heading), math.cos(heading))))
    return out
