"""Unload before the next job (issue 27): a robot back at base with a load (dirty laundry for
the wash, or clean laundry brought back after a cancellation) is not dispatched again until
its load cell (the data exchange's ``WeightKg``) has read below ``MinWeightKg`` for
``UnloadSettledS`` on end, or the staff say it is unloaded.

Sites without load cells (``RequireWeightCheck`` off) have nothing to read: no robot is held.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from enum import StrEnum

import structlog
from sqlalchemy.ext.asyncio import AsyncSession

from fleet.errors import Conflict
from fleet.models import Robot
from fleet.services.assignment import process_queue
from fleet.settings import FleetSettings

log = structlog.get_logger(__name__)


class Step(StrEnum):
    """What one report means for a robot waiting to be unloaded (each is a write)."""

    EMPTY = "empty"      # first reading below the minimum: the settling time starts
    LOADED = "loaded"    # above it again: the settling time starts over at the next empty one
    SETTLED = "settled"  # below it long enough: unloaded


def step(unload_pending: bool, clear_since: datetime | None, weight_kg: float | None,
         now: datetime, cfg: FleetSettings) -> Step | None:
    """None when the report changes nothing (most reports: no write needed)."""
    if not unload_pending:
        return None
    empty = weight_kg is not None and weight_kg < cfg.min_weight_kg
    if not empty:
        return Step.LOADED if clear_since is not None else None
    if clear_since is None:
        return Step.SETTLED if cfg.unload_settled_s == 0 else Step.EMPTY
    if now - clear_since >= timedelta(seconds=cfg.unload_settled_s):
        return Step.SETTLED
    return None


def hold(robot: Robot, now: datetime, cfg: FleetSettings, *, laundry_aboard: bool) -> None:
    """The robot is released at base: it waits to be unloaded if it brought laundry back or
    its load cell reads a load (a reading below the minimum already starts the settling
    time)."""
    if not cfg.require_weight_check:
        return
    empty = robot.weight_kg is not None and robot.weight_kg < cfg.min_weight_kg
    loaded = robot.weight_kg is not None and not empty
    if laundry_aboard or loaded:
        robot.unload_pending = True
        robot.unload_clear_since = now if empty else None
        log.info("fleet.robot.unload_wait", robot=robot.name, weight_kg=robot.weight_kg,
                 laundry_aboard=laundry_aboard)


async def apply(session: AsyncSession, now: datetime, cfg: FleetSettings, robot: Robot) -> None:
    """Apply the robot's latest weight (``robot.weight_kg``) to its wait."""
    found = step(robot.unload_pending, robot.unload_clear_since, robot.weight_kg, now, cfg)
    if found == Step.EMPTY:
        robot.unload_clear_since = now
    elif found == Step.LOADED:
        robot.unload_clear_since = None
    elif found == Step.SETTLED:
        await _unloaded(session, now, cfg, robot, by="load cell")


async def confirm_unloaded(
    session: AsyncSession, now: datetime, cfg: FleetSettings, robot: Robot
) -> None:
    """The staff say the robot is empty. Raises Conflict when it is not waiting for that."""
    if not robot.unload_pending:
        msg = f"robot {robot.name!r} is not waiting to be unloaded"
        raise Conflict(msg)
    await _unloaded(session, now, cfg, robot, by="staff")


async def _unloaded(session: AsyncSession, now: datetime, cfg: FleetSettings, robot: Robot,
                    *, by: str) -> None:
    robot.unload_pending = False
    robot.unload_clear_since = None
    log.info("fleet.robot.unloaded", robot=robot.name, by=by)
    await process_queue(session, now, cfg)
