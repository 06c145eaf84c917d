"""The site status report (``behaviours.site_report``) wired for any profile: when
``fleet.url`` is set and the profile does not report itself, the daemon runs one
``SiteReporter`` beside the profile's services, its e-stop orders taking the daemon's e-stop."""

from __future__ import annotations

import os

from behaviours.context import RobotContext
from behaviours.profile import Profile
from behaviours.service import Service
from behaviours.site_report.client import fleet_client, read_token, token_path
from behaviours.site_report.orders import EngageEstop, StaffOrders
from behaviours.site_report.reporter import SiteReporter
from behaviours.site_report.status import status_body


def site_report_services(profile: Profile, ctx: RobotContext,
                         engage_estop: EngageEstop) -> list[Service]:
    """The reporter, or nothing (no ``fleet.url``, or the profile reports itself). Raises
    ValueError (the daemon's start fails, naming it) for an unreadable token or CA file."""
    settings = ctx.settings
    url = str(settings.get("fleet.url"))
    if not url or profile.reports_itself:
        return []
    # Read once at start; a missing or unreadable file stops the start with its path.
    path = token_path(str(settings.get("fleet.token_file")), os.environ)
    token = read_token(path) if path is not None else None
    client = fleet_client(url, ctx.devices.network, str(settings.get("fleet.ca_file")))
    name = profile.name
    return [SiteReporter(client, str(settings.get("robot.name")),
                         lambda: status_body(ctx, name, profile.site_facts(ctx)),
                         StaffOrders(ctx, engage_estop),
                         period_s=lambda: float(settings.get("fleet.period_s")), token=token)]
