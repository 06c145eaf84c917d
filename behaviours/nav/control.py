"""Control-socket methods of a navigating profile: an operator's pose (``robotctl pose set``).

``<profile>.set_pose`` with ``x_m``, ``y_m``, ``heading_deg`` (the map frame) and optionally
``sigma_m``, ``sigma_deg`` (how sure the operator is): the filter is re-seeded round that pose
(``NavStack.set_pose``) and a drive under way plans again from it. A pose off the map or
inside an obstacle is refused as bad params, before the stack is touched.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from behaviours.nav.navigator import NavStack
from behaviours.profile import ControlMethod, ControlRefused

SET_POSE = "set_pose"
DEFAULT_SIGMA_M = 0.25
DEFAULT_SIGMA_DEG = 10.0
_KEYS = ("x_m", "y_m", "heading_deg", "sigma_m", "sigma_deg")


def _number(params: dict[str, Any], key: str, default: float | None = None) -> float:
    value = params.get(key, default)
    if value is None:
        msg = f"{key}: required"
        raise ValueError(msg)
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        msg = f"{key}: expected a number, got {value!r}"
        raise ValueError(msg)
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if not math.isfinite(number):
        msg = f"{key}: expected a number, got {value!r}"
        raise ValueError(msg)
    return number


def pose_methods(profile: str, stack: Callable[[], NavStack | None]
                 ) -> dict[str, ControlMethod]:
    """``<profile>.set_pose`` over the profile's navigation stack (None before it is built)."""

    async def set_pose(params: dict[str, Any]) -> dict[str, Any]:
        unknown = sorted(set(params) - set(_KEYS))
        if unknown:
            msg = f"unknown params {unknown} (known: {', '.join(_KEYS)})"
            raise ValueError(msg)
        x, y = _number(params, "x_m"), _number(params, "y_m")
        heading = _number(params, "heading_deg")
        sigma_m = _number(params, "sigma_m", DEFAULT_SIGMA_M)
        sigma_deg = _number(params, "sigma_deg", DEFAULT_SIGMA_DEG)
        if not 0 < sigma_m <= 10 or not 0 < sigma_deg <= 180:
            msg = "sigma_m must be in (0, 10] and sigma_deg in (0, 180]"
            raise ValueError(msg)
        nav = stack()
        if nav is None:
            msg = "the navigation stack is not running yet"
            raise ControlRefused(msg)
        x0, y0, x1, y1 = nav.planner.grid.bounds_m()
        if not (x0 <= x < x1 and y0 <= y < y1):
            msg = f"({x:.2f}, {y:.2f}) is off the map ({x0:.2f}..{x1:.2f}, {y0:.2f}..{y1:.2f})"
            raise ValueError(msg)
        row, col = nav.planner.grid.cell_of(x, y)
        if nav.planner.grid.occupied[row, col]:
            msg = f"({x:.2f}, {y:.2f}) is inside an obstacle of the map"
            raise ValueError(msg)
        nav.set_pose(x, y, math.radians(heading), sigma_m, math.radians(sigma_deg))
        return {"x_m": x, "y_m": y, "heading_deg": heading, "sigma_m": sigma_m,
                "sigma_deg": sigma_deg, "status": nav.localiser.status}

    return {f"{profile}.{SET_POSE}": set_pose}
