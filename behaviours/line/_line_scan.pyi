from typing import Any

def scan(image: Any, rows: Any, kind: int, wanted_mask: int, others_mask: int, level: float,
         grey_tint: int, blocks: int, radius: int, gap_px: int
         ) -> tuple[float, list[tuple[int, int, int, float, float]]]: ...
