"""ROS ``map_server`` maps (PGM + YAML, as ``map_saver`` writes them), read into a numpy grid.

A pure reader: no planning, no drawing. Both the navigation stack (``behaviours/nav``) and the
simulated world (``sim/world``) stand on it, which is why it sits in ``hal``.

The semantics are Nav2's ``map_io.cpp`` (``loadMapYaml`` / ``loadMapFromFile``):
- ``image`` is relative to the YAML file unless absolute; ``resolution`` m/cell; ``origin``
  ``[x, y, yaw]`` is the pose of the lower-left pixel's outer corner in the map frame;
- a pixel's shade is value / max value; occ = shade if ``negate`` else 1 - shade;
- ``mode: trinary`` (default): occ > occupied_thresh -> 100, occ < free_thresh -> 0, else -1
  (unknown); ``scale``: the same ends, values between scale linearly to 1..99;
  ``raw``: the value itself when 0..100, else unknown;
- image row 0 is the top of the map: grid row 0 here is the bottom (y grows upwards).

The YAML is the flat subset ``map_saver`` writes (``key: value`` lines, ``origin`` as a flow
list, ``#`` comments): PyYAML is no dependency of ours, and anything outside that subset is
answered with an error naming the line, never guessed at.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from hal.files import FileRefused, read_bounded, read_bounded_text

FREE = 0
OCCUPIED = 100
UNKNOWN = -1

_MODES = ("trinary", "scale", "raw")
MAX_YAML_BYTES = 64 * 1024
MAX_IMAGE_BYTES = 256 * 1024 * 1024
"""A map image's bound: 16k x 16k cells of 8 bits (the warehouse map is 1.7 MB)."""
_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
_MAX_CELLS = 20_000 * 20_000


class MapFileError(ValueError):
    """A map file that cannot be used; the message is ``PATH: what is wrong``."""


@dataclass(frozen=True, slots=True)
class OccupancyMap:
    """Cells (rows bottom-up: row 0 is the map's lowest y) of 0 free, 100 occupied, -1 unknown
    (``scale``/``raw``: 1..99 between), with their place in the map frame."""

    cells: npt.NDArray[np.int8]
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    source: str = "<memory>"

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])

    def occupied(self, occupied_min: int = 65, unknown_is_occupied: bool = False
                 ) -> npt.NDArray[np.bool_]:
        """Cells that are obstacles: at least ``occupied_min`` (trinary maps: 100 only)."""
        mask: npt.NDArray[np.bool_] = self.cells >= occupied_min
        if unknown_is_occupied:
            mask = mask | (self.cells < 0)
        return mask


def read_map_yaml(path: str | Path) -> OccupancyMap:
    """The map a ``map_server`` YAML file describes; MapFileError says ``PATH: what``."""
    path = Path(path)
    try:
        text = read_bounded_text(path, MAX_YAML_BYTES, "map YAML")
    except FileRefused as exc:
        raise MapFileError(str(exc)) from None
    meta = parse_map_yaml(text, str(path))
    image = Path(str(meta["image"])).expanduser()
    if not image.is_absolute():
        image = path.parent / image
    try:
        data = read_bounded(image, MAX_IMAGE_BYTES, "map image")
    except FileRefused as exc:
        msg = f"{path}: image: {exc}"
        raise MapFileError(msg) from None
    pixels, max_value = parse_pgm(data, str(image))
    return occupancy_from_pixels(pixels, max_value, meta, str(path))


def parse_map_yaml(text: str, where: str) -> dict[str, object]:
    """The YAML's keys, typed and checked (Nav2's required keys; ``mode`` defaults)."""
    raw: dict[str, tuple[int, str]] = {}
    for number, line in enumerate(text.splitlines(), 1):
        stripped = _strip_comment(line).strip()
        if not stripped or stripped == "---":
            continue
        m = re.fullmatch(r"([A-Za-z_][A-Za-z0-9_]*)\s*:\s*(.*)", stripped)
        if m is None or line[:1].isspace():
            # Not quoted: a path that is not a map (/etc/shadow) must not be echoed.
            msg = f"{where}:{number}: expected 'key: value'"
            raise MapFileError(msg)
        raw[m.group(1)] = (number, m.group(2).strip())
    meta: dict[str, object] = {}
    for key in ("image", "resolution", "origin", "occupied_thresh", "free_thresh"):
        if key not in raw:
            msg = f"{where}: {key}: required key is missing"
            raise MapFileError(msg)
    for key, (number, value) in raw.items():
        at = f"{where}:{number}: {key}"
        if key == "image":
            meta[key] = _unquote(value)
            if not meta[key]:
                msg = f"{at}: the image tag is empty"
                raise MapFileError(msg)
        elif key in ("resolution", "occupied_thresh", "free_thresh"):
            meta[key] = _number(value, at)
        elif key == "origin":
            meta[key] = _origin(value, at)
        elif key == "negate":
            meta[key] = _negate(value, at)
        elif key == "mode":
            mode = _unquote(value).lower()
            if mode not in _MODES:
                msg = f"{at}: expected one of {', '.join(_MODES)}"
                raise MapFileError(msg)
            meta[key] = mode
        # Other keys (map_saver's none; extensions such as elevation layers) are ignored, as
        # Nav2 ignores them.
    meta.setdefault("mode", "trinary")
    meta.setdefault("negate", False)
    resolution = float(meta["resolution"])  # type: ignore[arg-type]
    if not resolution > 0:
        msg = f"{where}:{raw['resolution'][0]}: resolution: must be > 0, got {resolution}"
        raise MapFileError(msg)
    free, occ = float(meta["free_thresh"]), float(meta["occupied_thresh"])  # type: ignore[arg-type]
    if not 0.0 <= free < occ <= 1.0:
        msg = (f"{where}: free_thresh ({free}) and occupied_thresh ({occ}) must satisfy "
               "0 <= free_thresh < occupied_thresh <= 1")
        raise MapFileError(msg)
    return meta


def _strip_comment(line: str) -> str:
    quote = ""
    for i, ch in enumerate(line):
        if ch in "'\"":
            quote = "" if quote == ch else (quote or ch)
        elif ch == "#" and not quote and (i == 0 or line[i - 1].isspace()):
            return line[:i]
    return line


def _unquote(value: str) -> str:
    if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"":
        return value[1:-1]
    return value


def _number(value: str, at: str) -> float:
    try:
        number = float(_unquote(value))
    except ValueError:
        number = math.nan
    if not math.isfinite(number):
        msg = f"{at}: expected a number"
        raise MapFileError(msg)
    return number


def _origin(value: str, at: str) -> tuple[float, float, float]:
    if not (value.startswith("[") and value.endswith("]")):
        msg = f"{at}: expected [x, y, yaw]"
        raise MapFileError(msg)
    parts = [p.strip() for p in value[1:-1].split(",") if p.strip()]
    if len(parts) != 3:
        msg = f"{at}: expected 3 elements [x, y, yaw], got {len(parts)}"
        raise MapFileError(msg)
    x, y, yaw = (_number(p, at) for p in parts)
    if abs(math.remainder(yaw, 2 * math.pi)) > 1e-6:
        # Nav2's planners and AMCL ignore the yaw too; a rotated map would be drawn wrongly
        # everywhere, so it is refused rather than half-honoured.
        msg = f"{at}: yaw {yaw} is not supported (only 0: rotate the image instead)"
        raise MapFileError(msg)
    return x, y, 0.0


def _negate(value: str, at: str) -> bool:
    word = _unquote(value).lower()
    if word in ("0", "false", "no", "off"):
        return False
    if word in ("1", "true", "yes", "on"):
        return True
    msg = f"{at}: expected 0 or 1"
    raise MapFileError(msg)


def parse_pgm(data: bytes, where: str) -> tuple[npt.NDArray[np.uint16], int]:
    """Pixels (top row first) and max value of a binary (P5) or plain (P2) PGM."""
    tokens: list[bytes] = []
    pos = 0
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        msg = f"{where}: not a PGM image (it does not start with P5 or P2)"
        raise MapFileError(msg)
    pos = 2
    while len(tokens) < 3:
        while pos < len(data) and (data[pos:pos + 1].isspace() or data[pos:pos + 1] == b"#"):
            if data[pos:pos + 1] == b"#":
                end = data.find(b"\n", pos)
                pos = len(data) if end < 0 else end
            pos += 1
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace() and data[pos:pos + 1] != b"#":
            pos += 1
        if start == pos:
            msg = f"{where}: PGM header is truncated"
            raise MapFileError(msg)
        tokens.append(data[start:pos])
    try:
        width, height, max_value = (int(t) for t in tokens)
    except ValueError as exc:
        msg = f"{where}: PGM header: expected width, height and maxval, got {tokens!r}"
        raise MapFileError(msg) from exc
    if width <= 0 or height <= 0 or width * height > _MAX_CELLS:
        msg = f"{where}: PGM size {width}x{height} is out of range"
        raise MapFileError(msg)
    if not 0 < max_value < 65536:
        msg = f"{where}: PGM maxval must be 1-65535, got {max_value}"
        raise MapFileError(msg)
    count = width * height
    if magic == b"P2":
        try:
            values = np.array(data[pos:].split(), dtype=np.int64)
        except ValueError as exc:
            msg = f"{where}: plain PGM pixels are not all integers"
            raise MapFileError(msg) from exc
        if values.size < count:
            msg = f"{where}: image data is truncated ({values.size} of {count} pixels)"
            raise MapFileError(msg)
        pixels = values[:count]
    else:
        pos += 1  # exactly one whitespace byte ends the header of a P5
        size = 2 if max_value > 255 else 1
        body = data[pos:pos + count * size]
        if len(body) < count * size:
            msg = (f"{where}: image data is truncated ({len(body) // size} of {count} "
                   "pixels)")
            raise MapFileError(msg)
        pixels = np.frombuffer(body, dtype=">u2" if size == 2 else np.uint8).astype(np.int64)
    if int(pixels.max(initial=0)) > max_value:
        msg = f"{where}: a pixel exceeds maxval {max_value}"
        raise MapFileError(msg)
    return pixels.reshape(height, width).astype(np.uint16), max_value


def occupancy_from_pixels(pixels: npt.NDArray[np.uint16], max_value: int,
                          meta: dict[str, object], where: str) -> OccupancyMap:
    """Nav2's pixel -> cell rule over a whole image (top row first in, bottom row first out)."""
    shade = pixels.astype(np.float64) / max_value
    occ = shade if meta["negate"] else 1.0 - shade
    free_t = float(meta["free_thresh"])  # type: ignore[arg-type]
    occ_t = float(meta["occupied_thresh"])  # type: ignore[arg-type]
    mode = meta["mode"]
    cells = np.full(pixels.shape, UNKNOWN, dtype=np.int8)
    if mode == "raw":
        value = np.rint(shade * 255)
        inside = (value >= FREE) & (value <= OCCUPIED)
        cells[inside] = value[inside].astype(np.int8)
    else:
        if mode == "scale":
            between = np.rint((occ - free_t) / (occ_t - free_t) * 100.0)
            cells = np.clip(between, 0, 100).astype(np.int8)
        cells[occ > occ_t] = OCCUPIED
        cells[occ < free_t] = FREE
    origin: tuple[float, float, float] = meta["origin"]  # type: ignore[assignment]
    resolution: float = meta["resolution"]  # type: ignore[assignment]
    return OccupancyMap(np.ascontiguousarray(cells[::-1]), float(resolution),
                        float(origin[0]), float(origin[1]), where)
