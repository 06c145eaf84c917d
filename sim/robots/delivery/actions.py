"""Script actions around the delivery robot: warehouse staff confirm the loading, a customer
holds up a (different) QR code."""

from __future__ import annotations

from collections.abc import Awaitable
from typing import Any

import structlog

from sim.actions.people import _person
from sim.actions.step import Action, Step
from sim.devices.frame_source import FrameSource
from sim.scenario import ScenarioError
from sim.world.snag import snag_action

log = structlog.get_logger(__name__)

STEP_IN_GAP_M = 0.04


async def _confirm(step: Step) -> None:
    """``staff.confirm_loaded``: a worker runs ``robotctl confirm-loaded --by NAME``; the
    call goes through the daemon's own control handler, as the socket's would."""
    from robotd.control.methods import control_handlers
    from robotd.control.rpc import RpcError

    assert step.daemons is not None
    daemon = step.daemons.robots[step.robot].daemon
    handler = control_handlers(daemon).get("delivery.confirm_loaded")
    if handler is None:
        msg = f"{step.robot} has no delivery.confirm_loaded (its profile is not delivery)"
        raise ScenarioError(msg)
    try:
        await handler({"by": str(step.args.get("name", "staff"))}, None)  # type: ignore[arg-type]
    except RpcError as exc:  # refused (not loading): the staff's press is logged, not fatal
        log.warning("sim.confirm_refused", error=str(exc))


async def _trigger(step: Step) -> None:
    from robotd.control.methods import control_handlers
    from robotd.control.rpc import RpcError

    assert step.daemons is not None
    daemon = step.daemons.robots[step.robot].daemon
    try:
        await control_handlers(daemon)["trigger"]({"name": str(step.args.get("name", ""))},
                                                  None)  # type: ignore[arg-type]
    except RpcError as exc:
        log.warning("sim.trigger_refused", error=str(exc))


def _robotctl_trigger(step: Step) -> Awaitable[None] | None:
    """``robotctl.trigger``: an operator fires the machine trigger ``name`` (``robotctl
    trigger NAME``), e.g. ``error`` for a fault seen by someone rather than a sensor."""
    if step.daemons is None:
        return None
    return _trigger(step)


def _confirm_loaded(step: Step) -> Awaitable[None] | None:
    if step.daemons is None:
        return None
    return _confirm(step)


def _show_qr(step: Step) -> None:
    """``person.show_qr``: ``name`` now holds up the code of ``value`` (a string; "" for
    none) to the robot's forward camera."""
    person = _person(step)
    value = step.args.get("value", "")
    if not isinstance(value, str):
        msg = "person.show_qr: value: expected the code's text"
        raise ScenarioError(msg)
    person.qr_payload = value or None


def _servo_fail(step: Step) -> None:
    """``servo.fail``: the box servo jams (the board refuses SERVO); ``duration_s``: freed
    again after that long."""
    board = step.rig.mcu
    board.servo_fault = True
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: setattr(board, "servo_fault", False), "servo.fixed")


def _qr_camera(step: Step) -> FrameSource[Any]:
    reader = step.rig.devices.qr
    camera = getattr(reader, "camera", None)
    if not isinstance(camera, FrameSource):
        msg = "qr_camera.unplug/replug: this robot has no simulated QR camera"
        raise ScenarioError(msg)
    return camera


def _qr_camera_unplug(step: Step) -> None:
    """``qr_camera.unplug``: the forward camera's cable is pulled (reads fail);
    ``duration_s``: plugged back after that long."""
    camera = _qr_camera(step)
    camera.unplug()
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, camera.replug, "qr_camera.replug")


def _qr_camera_replug(step: Step) -> None:
    _qr_camera(step).replug()


def _step_in(step: Step) -> None:
    """``person.step_in``: ``name`` steps (or reaches: a small ``radius_m`` person is a hand)
    right in front of the robot, ``STEP_IN_GAP_M`` from its nose; ``duration_s``: gone
    again after that long. What the front IR sensor sees under 10 cm (the error table's
    obstacle collision) or a hand in the box opening."""
    person = _person(step)
    body = step.rig.body
    pose = body.pose
    ahead = STEP_IN_GAP_M + body.params.radius_m + person.radius_m
    person.walk = None
    person.x_m, person.y_m = pose.to_world(ahead, 0.0)
    person.present = True
    duration = step.duration_s()
    if duration is not None:
        step.later(duration, lambda: setattr(person, "present", False), "person.stepped_out")


DELIVERY_ACTIONS: dict[str, Action] = {
    "body.snag": snag_action,
    "person.step_in": _step_in,
    "qr_camera.unplug": _qr_camera_unplug,
    "qr_camera.replug": _qr_camera_replug,
    "servo.fail": _servo_fail,
    "robotctl.trigger": _robotctl_trigger,
    "staff.confirm_loaded": _confirm_loaded,
    "person.show_qr": _show_qr,
}
