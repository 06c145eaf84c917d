"""The robots as a table of their views (``RobotView``): the site map's list and the robot
page's summary show the same columns."""

from __future__ import annotations

from collections.abc import Sequence
from urllib.parse import quote

from fleet.console.html import esc, when
from fleet.console.robot_views import RobotView


def robot_link(name: str) -> str:
    return f'<a href="/robots/{esc(quote(name, safe=""))}">{esc(name)}</a>'


def views_table(views: Sequence[RobotView]) -> str:
    if not views:
        return '<p class="empty">No robots registered.</p>'
    rows = "".join(_row(v) for v in views)
    return ("<table><thead><tr><th>Robot</th><th>Profile</th><th>Condition</th><th>State</th>"
            "<th>Place or pose</th>"
            "<th>Battery</th><th>Fault</th><th>Job</th><th>Last seen</th></tr></thead>"
            f"<tbody>{rows}</tbody></table>")


def _row(view: RobotView) -> str:
    battery = "-" if view.battery_pct is None else f"{view.battery_pct:.0f} %"
    fault = "-" if view.fault_code is None else f"{view.fault_code}: {view.fault_message or ''}"
    where = view.place or "-"
    if view.place is None and view.x_m is not None:
        where = f"{view.x_m:.2f}, {view.y_m or 0:.2f} m on {view.map_name or '?'}"
    return (f'<tr id="view-{esc(view.name)}" data-condition="{view.condition}">'
            f"<td>{robot_link(view.name)}</td><td>{esc(view.profile or '-')}</td>"
            f'<td><span class="status c-{view.condition}">{view.condition}</span></td>'
            f"<td>{esc(view.state or '-')}</td><td>{esc(where)}</td>"
            f"<td>{esc(battery)}</td><td>{esc(fault)}</td><td>{esc(view.job or '-')}</td>"
            f"<td>{esc(when(view.last_seen) or 'never')}</td></tr>")
