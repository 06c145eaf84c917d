"""The staff console's sections: the request board, the robots and the open alerts.

Each is a function of what the API shows (``RequestOut``, ``RobotOut``, ``AlertOut``), so the
page and the API cannot tell different stories. A request's buttons are the actions its status
allows (``fleet.status.ALLOWED``), each a POST form with the session's CSRF token.
"""

from __future__ import annotations

from urllib.parse import quote

from fleet.api.schemas import AlertOut, RequestOut, RobotOut
from fleet.console.html import button_form, esc, when
from fleet.status import ALLOWED, Action, Status

# The staff's buttons on the board, in the order shown.
BOARD_ACTIONS = (Action.ACCEPT, Action.DECLINE, Action.WASHING_DONE, Action.CANCEL)
_LABELS = {Action.ACCEPT: "Accept", Action.DECLINE: "Decline",
           Action.WASHING_DONE: "Washing done", Action.CANCEL: "Cancel"}


def staff_actions(request: RequestOut) -> list[Action]:
    """The board's buttons for a request: what its status allows now."""
    status = Status(request.Status)
    shown = []
    for action in BOARD_ACTIONS:
        if status not in ALLOWED[action]:
            continue
        if action == Action.ACCEPT and request.IsApproved:
            continue  # approved, waiting in the queue for a robot
        if action == Action.WASHING_DONE and request.DeliveryQueued:
            continue  # already done; its delivery waits for a robot
        shown.append(action)
    return shown


def board(requests: list[RequestOut], customers: dict[int, str], csrf: str) -> str:
    if not requests:
        return '<p class="empty">No requests yet.</p>'
    rows = "".join(_request_row(r, customers.get(r.CustomerId), csrf) for r in requests)
    return ("<table><thead><tr><th>#</th><th>Customer</th><th>Status</th><th>Robot</th>"
            "<th>Since</th><th>Actions</th></tr></thead>"
            f"<tbody>{rows}</tbody></table>")


def _request_row(request: RequestOut, customer: str | None, csrf: str) -> str:
    notes = []
    if request.Status == Status.PENDING:
        notes.append("approved, waiting for a robot" if request.IsApproved
                     else "needs approval")
    if request.IsPaid:
        notes.append("paid")
    if request.DeliveryQueued:
        notes.append("delivery queued")
    if request.AdminAlert:
        notes.append(request.AdminAlert)
    buttons = "".join(
        button_form(f"/console/requests/{request.Id}/{action}", _LABELS[action], csrf,
                    css="danger" if action in (Action.DECLINE, Action.CANCEL) else "",
                    name=str(action))
        for action in staff_actions(request))
    note = f'<div class="note">{esc(", ".join(notes))}</div>' if notes else ""
    return (f'<tr id="request-{request.Id}" data-status="{esc(request.Status)}">'
            f"<td>{request.Id}</td><td>{esc(customer or request.CustomerId)}</td>"
            f'<td><span class="status s-{esc(request.Status)}">{esc(request.Status)}</span>'
            f"{note}</td><td>{esc(request.AssignedRobotName or '-')}</td>"
            f"<td>{esc(when(request.StatusChangedAt))}</td><td>{buttons}</td></tr>")


def robots(rows: list[RobotOut]) -> str:
    if not rows:
        return '<p class="empty">No robots registered.</p>'
    body = "".join(_robot_row(r) for r in rows)
    return ("<table><thead><tr><th>Robot</th><th>Profile</th><th>Status</th><th>State</th>"
            "<th>Battery</th>"
            "<th>Fault</th><th>Waiting for</th><th>Request</th></tr></thead>"
            f"<tbody>{body}</tbody></table>")


def _robot_row(robot: RobotOut) -> str:
    battery = "-" if robot.BatteryPct is None else f"{robot.BatteryPct:.0f} %"
    fault = ("-" if robot.Fault is None
             else f"{esc(robot.Fault.Code)}: {esc(robot.Fault.Message)}")
    # A robot of the data exchange is a laundry robot (seed 000); others say their profile.
    profile = robot.Profile or ("laundry" if robot.LastPingAt is not None else "-")
    return (f'<tr id="robot-{esc(robot.Name)}" data-status="{esc(robot.Status)}">'
            f'<td><a href="/robots/{esc(quote(robot.Name, safe=""))}">{esc(robot.Name)}</a></td>'
            f"<td>{esc(profile)}</td>"
            f'<td><span class="status r-{esc(robot.Status)}">{esc(robot.Status)}</span></td>'
            f"<td>{esc(robot.State or '-')}</td><td>{esc(battery)}</td><td>{fault}</td>"
            f"<td>{esc(robot.WaitingFor or '-')}</td>"
            f"<td>{esc(robot.CurrentRequestId or '-')}</td></tr>")


def alerts(rows: list[AlertOut], csrf: str) -> str:
    if not rows:
        return '<p class="empty">No open alerts.</p>'
    return "".join(_alert(a, csrf) for a in rows)


def _alert(alert: AlertOut, csrf: str) -> str:
    seen = (f"seen by {esc(alert.AcknowledgedBy)}" if alert.AcknowledgedAt is not None
            else button_form(f"/console/alerts/{alert.Id}/acknowledge", "Acknowledge", csrf,
                             name="acknowledge"))
    about = " ".join(part for part in (
        f"robot {esc(alert.RobotName)}" if alert.RobotName else "",
        f"request {alert.RequestId}" if alert.RequestId is not None else "") if part)
    code = f" {alert.Code}" if alert.Code else ""
    return (f'<article id="alert-{alert.Id}" class="alert {esc(alert.Level)}" '
            f'data-code="{esc(alert.Code or "")}">'
            f"<h3>{esc(alert.Kind + code)} <small>{esc(about)}</small></h3>"
            f"<p>{esc(alert.Message)}</p><p class=\"note\">{esc(when(alert.CreatedAt))}</p>"
            f'<div class="actions">{seen}{_resolve_form(alert, csrf)}</div></article>')


def _resolve_form(alert: AlertOut, csrf: str) -> str:
    if not alert.IsLaundry:
        return button_form(f"/console/alerts/{alert.Id}/resolve", "Resolve", csrf,
                           name="resolve")
    return (f'<form method="post" action="/console/alerts/{alert.Id}/resolve" '
            f'class="inline"><input type="hidden" name="csrf" value="{esc(csrf)}">'
            f'<label>Laundry is <select name="LaundryAt" required>'
            '<option value="">where?</option><option value="robot">on the robot</option>'
            '<option value="base">at base</option>'
            '<option value="customer">back with the customer</option></select></label>'
            '<button type="submit" data-action="resolve">Resolve</button></form>')
