"""``drive``: a technician's teleoperation through the control socket (``robotctl drive``).

``drive {"linear_mps": v, "angular_rad_s": w}`` turns the wheels at ``v -+ w * b / 2`` for
``HOLD_S`` (0.5 s): a client keeps driving by sending it again (``robotctl drive --for S``
refreshes every 0.2 s); when no refresh comes, the motors stop (the deadman; the motor board's
own, 500 ms after its last command, is below it). ``v = w = 0`` stops at once. Allowed only
while the robot is ``idle`` or in ``maintenance`` (``robotd map``'s survey is idle while a
technician drives it), never in a mission, never in ``estop``: refused with a line that says
so. The e-stop wins: it stops the motors itself, and the next drive step sees the state and
ends, motors stopped.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from typing import TYPE_CHECKING, Any

import structlog

from behaviours.machine_tables import RootState
from behaviours.motion.config import DriveTuning
from behaviours.motion.odometry import Odometry
from behaviours.motion.waypoint_drive import wheel_command
from hal.tasks import cancel_and_wait
from robotd.control.rpc import APP_ERROR, INVALID_PARAMS, RpcError

if TYPE_CHECKING:
    from robotd.daemon import Daemon

log = structlog.get_logger(__name__)

HOLD_S = 0.5
PERIOD_S = 0.1
MAX_LINEAR_MPS = 1.0
MAX_ANGULAR_RAD_S = 3.0
ALLOWED = (RootState.IDLE, RootState.MAINTENANCE)


def allowed(state: str) -> bool:
    return any(state == s or state.startswith(s + ".") for s in ALLOWED)


class Teleop:
    """The one drive a daemon's clients share (the last command wins)."""

    def __init__(self, daemon: Daemon) -> None:
        self.d = daemon
        self.linear_mps = 0.0
        self.angular_rad_s = 0.0
        self.until_s = 0.0
        self.commands = 0
        self._task: asyncio.Task[None] | None = None
        daemon.add_event_listener(self._on_event)

    def _on_event(self, event: dict[str, Any]) -> None:
        """An e-stop (emitted before the daemon stops the motors) ends the drive at once: no
        drive step can come between the e-stop's motor stop and its state."""
        if event.get("kind") == "estop" and self._task is not None:
            self.until_s = 0.0
            self._task.cancel()

    async def drive(self, params: dict[str, Any]) -> dict[str, Any]:
        v = _number(params, "linear_mps", MAX_LINEAR_MPS)
        w = _number(params, "angular_rad_s", MAX_ANGULAR_RAD_S)
        unknown = sorted(set(params) - {"linear_mps", "angular_rad_s"})
        if unknown:
            raise RpcError(INVALID_PARAMS, f"drive: unknown params {unknown} "
                           "(known: linear_mps, angular_rad_s)")
        state = self.d.state
        if not allowed(state):
            raise RpcError(APP_ERROR, f"drive: refused in state {state}: a technician drives "
                           "only an idle robot or one in maintenance (robotd map keeps it idle)")
        if self.d.devices.motors is None:
            raise RpcError(APP_ERROR, "drive: this robot has no motors")
        loop = asyncio.get_running_loop()
        self.linear_mps, self.angular_rad_s = v, w
        self.until_s = loop.time() + HOLD_S
        self.commands += 1
        if v == 0.0 and w == 0.0:
            await self.stop("asked")
        elif self._task is None or self._task.done():
            self.d.emit("teleop.drive", linear_mps=v, angular_rad_s=w, state=state)
            self._task = asyncio.create_task(self._run(), name="teleop")
        return {"linear_mps": v, "angular_rad_s": w, "hold_s": HOLD_S, "state": state}

    async def stop(self, reason: str) -> None:
        task, self._task = self._task, None
        if task is not None and not task.done() and task is not asyncio.current_task():
            await cancel_and_wait(task)
            await self.d.stop_motors()
            self.d.emit("teleop.stopped", reason=reason)

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        motors = self.d.devices.motors
        assert motors is not None
        reason = "deadman"
        try:
            while loop.time() < self.until_s:
                if not allowed(self.d.state):
                    reason = f"state {self.d.state}"
                    break
                tuning = DriveTuning.from_settings(self.d.settings)
                half = self.angular_rad_s * Odometry.from_settings(
                    self.d.settings).wheel_base_m / 2
                command = wheel_command(self.linear_mps - half, self.linear_mps + half, tuning)
                with contextlib.suppress(Exception):  # a link down: the board's deadman stops
                    await motors.drive(command)
                await asyncio.sleep(PERIOD_S)
        except asyncio.CancelledError:
            reason = "estop"
            raise
        finally:
            if self._task is asyncio.current_task() or reason == "estop":
                self._task = None
                await self.d.stop_motors()
                self.d.emit("teleop.stopped", reason=reason)
                log.info("teleop.stopped", reason=reason, commands=self.commands)


def _number(params: dict[str, Any], key: str, limit: float) -> float:
    value = params.get(key, 0.0)
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or abs(value) > limit:
        raise RpcError(INVALID_PARAMS, f"drive: {key}: expected a number within +-{limit}, "
                       f"got {value!r}")
    return float(value)
