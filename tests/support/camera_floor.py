"""The floor the simulated camera's tests look at: a black loop with a red spur across it."""

from __future__ import annotations

from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import segments_array

LOOP_AND_SPUR = (
    PaintedLine("loop", ((0.5, 0.5), (3.5, 0.5), (3.5, 2.5), (0.5, 2.5)), "black", 0.025,
                closed=True),
    PaintedLine("spur", ((2.0, 0.5), (2.0, 2.5)), "red", 0.02),
)


def loop_world(*extra: PaintedLine) -> World:
    """A 4 x 3 m floor with the loop, the spur and any ``extra`` lines."""
    return World(4.0, 3.0, segments_array([]), lines=[*LOOP_AND_SPUR, *extra])
