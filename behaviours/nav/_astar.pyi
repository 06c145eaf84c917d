from typing import Any

def search(cost: Any, start: int, goal: int, resolution_m: float
           ) -> tuple[list[int], float, int]: ...
