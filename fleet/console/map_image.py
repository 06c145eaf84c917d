"""A site's map for the console: a map_server YAML (``image``, ``resolution``, ``origin``)
and its PGM, the picture converted once to PNG for the browser.

A map's frame: ``origin`` is the world pose of the image's lower-left pixel; a pixel is
``resolution`` metres; image rows grow downwards while y grows upwards, so a point (x, y) is
drawn at column ``(x - origin_x) / resolution`` and row ``height - (y - origin_y) /
resolution``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import cv2
import yaml

MAX_PIXELS = 16_000_000
"""A bigger picture is refused (a 4000 x 4000 map at 5 cm is a 200 m square)."""


class MapError(ValueError):
    """A map that cannot be shown; the message names the file and what is wrong."""


@dataclass(frozen=True)
class SiteMap:
    name: str
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    width_px: int
    height_px: int
    png: bytes

    def pixel(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Where the world point (x, y) is drawn on the picture (column, row)."""
        return ((x_m - self.origin_x_m) / self.resolution_m,
                self.height_px - (y_m - self.origin_y_m) / self.resolution_m)


@functools.lru_cache(maxsize=4)
def load_map(yaml_path: Path) -> SiteMap:
    """The map of this YAML file, its picture as PNG (read and converted once)."""
    try:
        doc = yaml.safe_load(yaml_path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        msg = f"{yaml_path}: cannot read the map: {exc}"
        raise MapError(msg) from exc
    if not isinstance(doc, dict):
        msg = f"{yaml_path}: not a map_server YAML (a mapping of image, resolution, origin)"
        raise MapError(msg)
    image, resolution, origin = doc.get("image"), doc.get("resolution"), doc.get("origin")
    if not isinstance(image, str) or not isinstance(resolution, int | float) or \
            resolution <= 0 or not isinstance(origin, list) or len(origin) < 2 or \
            not all(isinstance(v, int | float) for v in origin[:2]):
        msg = (f"{yaml_path}: needs image (a file name), resolution (> 0, metres a pixel) "
               "and origin ([x, y, theta])")
        raise MapError(msg)
    picture_path = (yaml_path.parent / image).resolve()
    picture = cv2.imread(str(picture_path), cv2.IMREAD_GRAYSCALE)
    if picture is None:
        msg = f"{yaml_path}: image {image!r}: cannot read {picture_path}"
        raise MapError(msg)
    height, width = picture.shape[:2]
    if width * height > MAX_PIXELS:
        msg = f"{yaml_path}: image {width}x{height} is larger than {MAX_PIXELS} pixels"
        raise MapError(msg)
    ok, png = cv2.imencode(".png", picture)
    if not ok:
        msg = f"{yaml_path}: cannot convert {picture_path} to PNG"
        raise MapError(msg)
    return SiteMap(name=yaml_path.stem, resolution_m=float(resolution),
                   origin_x_m=float(origin[0]), origin_y_m=float(origin[1]),
                   width_px=int(width), height_px=int(height), png=png.tobytes())
