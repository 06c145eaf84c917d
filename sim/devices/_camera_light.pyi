from typing import Any

def light(paint: Any, texture: Any, static_gain: Any, ambient: Any, noise: Any, noise_row: int,
          noise_col: int, out: Any) -> None: ...
def light_rows(paint: Any, texture: Any, matrix: tuple[float, float, float, float, float, float],
               static_gain: Any, ambient: Any, noise: Any, noise_row: int, noise_col: int,
               rows: Any, out: Any) -> None: ...
def place_segments(ends: Any, x: float, y: float, c: float, s: float, limit: float,
                   half_w: float, half_h: float, m_per_px: float, forward_m: float,
                   scale: float) -> tuple[list[tuple[tuple[int, int], tuple[int, int]]],
                                          float, float, float, float] | None: ...
def ambient_coarse(fwd: Any, left: Any, x: float, y: float, c: float, s: float,
                   phases: tuple[float, float, float, float], variation: float,
                   out: Any) -> None: ...
