"""A* over a grid of cell costs: 8-connected, octile heuristic, on flat cell indices.

The graph: a cell is a node when its cost is finite; a move to one of the 8 neighbours costs
its length (1 or sqrt 2 cells, times the resolution) times the cost of the cell entered (>= 1,
so the octile distance never overestimates and A* is optimal). The open list is a heap of
(f, index) pairs with lazy deletion; ties go to the lower index, so the C kernel
(``_astar.c``, built by setup.py when a compiler is there) and the Python one here make the
same decisions and return the same path: tests/behaviours/nav hold them to it.
"""

from __future__ import annotations

import heapq
import math
import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import structlog

try:
    from behaviours.nav import _astar
except ImportError:  # not built (no compiler when installed): the Python kernel
    _astar = None  # type: ignore[assignment]

log = structlog.get_logger(__name__)

KERNELS = ("c", "python")
KERNEL_ENV = "ROBOTD_ASTAR_KERNEL"
_SQRT2 = math.sqrt(2.0)
_OCTILE = _SQRT2 - 2.0


@dataclass(frozen=True, slots=True)
class Search:
    """What a search found: cell indices from start to goal (empty: none), the path's
    cost in metres-times-cost, and how many cells were expanded."""

    cells: list[int]
    cost: float
    expanded: int


def built_kernel() -> str:
    """``ROBOTD_ASTAR_KERNEL`` if it names a usable kernel, else C when built, else Python."""
    built = "c" if _astar is not None else "python"
    wanted = os.environ.get(KERNEL_ENV, "").strip().lower()
    if wanted in ("python", built):
        return wanted
    if wanted:
        log.warning("astar.kernel_env_ignored", value=wanted, using=built)
    return built


def search(cost: npt.NDArray[np.float64], start: int, goal: int, resolution_m: float,
           kernel: str | None = None) -> Search:
    """Cheapest path between two cells of ``cost`` (2-D, inf = not a node)."""
    name = kernel or built_kernel()
    flat = np.ascontiguousarray(cost, dtype=np.float64)
    rows, cols = flat.shape
    if name == "c":
        if _astar is None:
            msg = "the C A* kernel was not built (pip install needs a C compiler)"
            raise ValueError(msg)
        cells, total, expanded = _astar.search(flat, start, goal, resolution_m)
        return Search(cells, total, expanded)
    if name == "python":
        return search_python(flat.ravel().tolist(), rows, cols, start, goal, resolution_m)
    msg = f"A* kernel {name!r}: expected one of {', '.join(KERNELS)}"
    raise ValueError(msg)


def search_python(cost: list[float], rows: int, cols: int, start: int, goal: int,
                  resolution_m: float) -> Search:
    """The Python kernel: flat indices, precomputed neighbour offsets, heapq on (f, index)."""
    inf = math.inf
    n = rows * cols
    g = [inf] * n
    parent = [-1] * n
    closed = bytearray(n)
    diag = _SQRT2 * resolution_m
    # (offset, d_row, d_col, length): neighbours as flat offsets, checked against the edges.
    moves = [(dr * cols + dc, dr, dc, diag if dr and dc else resolution_m)
             for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    goal_r, goal_c = divmod(goal, cols)
    g[start] = 0.0
    heap = [(_h(start, cols, goal_r, goal_c, resolution_m), start)]
    expanded = 0
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        _f, cur = pop(heap)
        if closed[cur]:
            continue
        closed[cur] = 1
        expanded += 1
        if cur == goal:
            return Search(_walk_back(parent, goal), g[goal], expanded)
        r, c = divmod(cur, cols)
        g_cur = g[cur]
        for offset, dr, dc, length in moves:
            nr, nc = r + dr, c + dc
            if nr < 0 or nr >= rows or nc < 0 or nc >= cols:
                continue
            nxt = cur + offset
            step = cost[nxt]
            if step == inf or closed[nxt]:
                continue
            g_new = g_cur + length * step
            if g_new < g[nxt]:
                g[nxt] = g_new
                parent[nxt] = cur
                push(heap, (g_new + _h(nxt, cols, goal_r, goal_c, resolution_m), nxt))
    return Search([], inf, expanded)


def _h(cell: int, cols: int, goal_r: int, goal_c: int, resolution_m: float) -> float:
    r, c = divmod(cell, cols)
    dr, dc = abs(r - goal_r), abs(c - goal_c)
    return (dr + dc + _OCTILE * min(dr, dc)) * resolution_m


def _walk_back(parent: list[int], goal: int) -> list[int]:
    cells = [goal]
    while parent[cells[-1]] >= 0:
        cells.append(parent[cells[-1]])
    cells.reverse()
    return cells
