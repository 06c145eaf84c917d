"""The daemon runs the site status report for any profile with ``fleet.url`` (issue 29), and
none without it or for a profile that reports itself (the laundry data exchange)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from behaviours.context import RobotContext
from behaviours.profiles.laundry.profile import LaundryProfile
from behaviours.profiles.vacuum.profile import VacuumProfile
from behaviours.site_report.client import TokenFileError
from behaviours.site_report.reporter import SiteReporter
from hal.backend import Devices
from hal.ports import system_wall_clock
from robotd.config import Settings
from robotd.config.loader import defaults
from robotd.site_link import site_report_services


class DictStore(dict[str, Any]):
    def put(self, key: str, value: Any) -> None:
        self[key] = value

    def delete(self, key: str) -> None:
        self.pop(key, None)


def context(**fleet: str) -> RobotContext:
    settings = Settings(defaults())
    for key, value in fleet.items():
        settings.set(f"fleet.{key}", value)
    return RobotContext(Devices(), settings, DictStore(), system_wall_clock,
                        lambda kind, **f: None)


async def engage(reason: str, source: str) -> bool:
    return True


class TestWiring:
    def test_no_fleet_url_no_report(self) -> None:
        assert site_report_services(VacuumProfile(), context(), engage) == []

    def test_a_profile_that_reports_itself_gets_none(self) -> None:
        ctx = context(url="http://fleet.local")
        assert site_report_services(LaundryProfile(), ctx, engage) == []

    def test_any_other_profile_reports_with_its_token(self, tmp_path: Path) -> None:
        token = tmp_path / "token"
        token.write_text("robot-token-0123456789abcdef\n")
        ctx = context(url="http://fleet.local", token_file=str(token))
        [reporter] = site_report_services(VacuumProfile(), ctx, engage)
        assert isinstance(reporter, SiteReporter)
        assert reporter.headers == {"Authorization": "Bearer robot-token-0123456789abcdef"}
        assert reporter.path == f"/api/Robot/{ctx.settings.get('robot.name')}/status"

    def test_an_unreadable_token_file_stops_the_start_naming_it(self, tmp_path: Path) -> None:
        ctx = context(url="http://fleet.local", token_file=str(tmp_path / "missing"))
        with pytest.raises(TokenFileError, match="missing"):
            site_report_services(VacuumProfile(), ctx, engage)
