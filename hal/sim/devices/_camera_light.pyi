from typing import Any

def light(paint: Any, texture: Any, static_gain: Any, ambient: Any, noise: Any, noise_row: int,
          noise_col: int, out: Any) -> None: ...
