"""The staff's orders to one robot from its console page: e-stop, resume, maintenance.

Each is the server's order as ``PATCH /api/robots/{name}`` gives it (``EmergencyStop``,
``MaintenanceMode``, through ``fleet.services.admin.update_robot``), delivered to the robot in
its next data exchange's reply. ``resume`` lifts the server's e-stop; a robot's own latch (its
e-stop pressed on the robot) is released on the robot (``robotctl resume``), as the design's
e-stop rule says: a person resumes it.
"""

from __future__ import annotations

from dataclasses import dataclass

import structlog

from fleet.errors import Conflict, NotFound
from fleet.server import FleetServer
from fleet.services import admin
from fleet.services.common import robot_by_name

log = structlog.get_logger(__name__)


@dataclass(frozen=True)
class RobotAction:
    label: str
    estop: bool | None = None
    maintenance: bool | None = None
    css: str = ""


ACTIONS = {
    "estop": RobotAction("Emergency stop", estop=True, css="danger"),
    "resume": RobotAction("Resume", estop=False),
    "maintenance": RobotAction("Maintenance", maintenance=True),
    "end-maintenance": RobotAction("End maintenance", maintenance=False),
}


def allowed(estop: bool, maintenance: bool) -> dict[str, str | None]:
    """Each action, None when it may be done now, else why not (the button's title)."""
    return {
        "estop": "already stopped by the server" if estop else None,
        "resume": None if estop else "no e-stop of the server's to lift",
        "maintenance": "already in maintenance" if maintenance else None,
        "end-maintenance": None if maintenance else "not in maintenance",
    }


async def act_on_robot(server: FleetServer, name: str, action: str, by: str) -> None:
    """Give the robot this order (404: no such robot or action; 409: not now)."""
    order = ACTIONS.get(action)
    if order is None:
        msg = f"no such robot action: {action}"
        raise NotFound(msg)
    await server.flush_pings()  # a robot released now is dispatched on its latest report
    async with server.db.write() as session:
        robot = await robot_by_name(session, name)
        if robot is None:
            msg = f"robot {name!r} is not registered"
            raise NotFound(msg)
        why_not = allowed(robot.emergency_stop, robot.maintenance_mode)[action]
        if why_not is not None:
            msg = f"{order.label}: {name}: {why_not}"
            raise Conflict(msg)
        await admin.update_robot(session, server.clock(), robot, is_active=None,
                                 emergency_stop=order.estop,
                                 maintenance_mode=order.maintenance)
    log.info("fleet.console.robot_order", robot=name, action=action, by=by)
