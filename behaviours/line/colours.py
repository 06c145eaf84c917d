"""Line colours: the FollowColor names and ``#RRGGBB`` codes a line tracker follows.

The fleet server names the colour of the line to follow (seed 000 section 8, FollowColor);
each name is a kind of score the tracker computes: "dark" (dark and grey on a light floor),
"light" (bright and grey) or "chroma" (the wanted colour channels stand out over the others).
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

DEFAULT_COLOUR = "black"

# Channels: B=0, G=1, R=2.
NAMED: dict[str, tuple[str, tuple[int, ...]]] = {
    "black": ("dark", ()),
    "dark": ("dark", ()),
    "white": ("light", ()),
    "red": ("chroma", (2,)),
    "green": ("chroma", (1,)),
    "blue": ("chroma", (0,)),
    "yellow": ("chroma", (1, 2)),
    "cyan": ("chroma", (0, 1)),
    "magenta": ("chroma", (0, 2)),
}
_HUES = {"red": 0.0, "yellow": 60.0, "green": 120.0, "cyan": 180.0, "blue": 240.0,
         "magenta": 300.0}


@dataclass(frozen=True, slots=True)
class LineColour:
    """A parsed colour name: the score ``kind`` and, for "chroma", the wanted channels."""

    name: str
    kind: str
    channels: tuple[int, ...]


def parse_colour(name: str | None) -> str:
    """Normalise a FollowColor value (a name or ``#RRGGBB``); ValueError says what is known."""
    if name is None or not name.strip():
        return DEFAULT_COLOUR
    text = name.strip().lower()
    if text in NAMED:
        return "black" if text == "dark" else text
    if text.startswith("#") and len(text) == 7:
        try:
            r, g, b = (int(text[i:i + 2], 16) / 255 for i in (1, 3, 5))
        except ValueError:
            pass
        else:
            hue, sat, val = colorsys.rgb_to_hsv(r, g, b)
            if sat < 0.3:
                return "black" if val < 0.5 else "white"
            deg = hue * 360
            return min(_HUES, key=lambda n: min(abs(deg - _HUES[n]), 360 - abs(deg - _HUES[n])))
    msg = f"line colour {name!r}: expected one of {', '.join(sorted(NAMED))} or #RRGGBB"
    raise ValueError(msg)


def line_colour(name: str) -> LineColour:
    """The colour a parsed name (``parse_colour``'s result) stands for."""
    kind, channels = NAMED[name]
    return LineColour(name, kind, channels)
