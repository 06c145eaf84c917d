from typing import Any

def light(paint: Any, texture: Any, static_gain: Any, ambient: Any, noise: Any, noise_row: int,
          noise_col: int, out: Any) -> None: ...
def light_rows(paint: Any, texture: Any, matrix: tuple[float, float, float, float, float, float],
               static_gain: Any, ambient: Any, noise: Any, noise_row: int, noise_col: int,
               rows: Any, out: Any) -> None: ...
