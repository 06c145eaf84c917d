"""The staff console's site map, robot page and alerts in a real browser (issue 29): a real
``robotd-fleet serve``, headless Debian chromium, robots reporting over HTTP from threads.

- A robot that falls silent with laundry aboard raises an alert that appears on the board
  without a reload; the staff resolve it saying where the laundry is, and it is gone.
- The site map shows each robot at its place; when a robot is sent out its marker moves,
  pushed, without a reload. The robot page e-stops a robot with its button.

With ``ROBOTD_CONSOLE_SCREENSHOTS=DIR`` it saves ``console-site.png`` and
``console-robot.png`` there.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select, WebDriverWait
from test_console_browser import (
    CHROMEDRIVER,
    CHROMIUM,
    CUSTOMER_TOKEN,
    ROOM_MAC,
    SITE,
    STAFF_TOKEN,
    WAIT_S,
    Robot,
    beacon,
    chromium,
    click,
    fleet_serve,
    log_in,
    mark,
    not_reloaded,
    screenshot,
    subscribed,
    wait_for,
)

pytestmark = pytest.mark.skipif(
    not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
    reason=f"needs Debian's chromium and chromium-driver ({CHROMIUM}, {CHROMEDRIVER}): "
           "scripts/bootstrap --test installs them")

QUICK_SITE = SITE.replace("AutoAccept = false            # the staff accept each request "
                          "on the console",
                          "AutoAccept = true\nOfflineAfterS = 3.0\nOfflineCheckPeriodS = 1.0")


@pytest.fixture
def quick_server(tmp_path: Path) -> Iterator[str]:
    """The browser test's site, requests accepted at once, a robot offline after 3 s."""
    assert QUICK_SITE != SITE
    with fleet_serve(tmp_path, QUICK_SITE) as url:
        yield url


def as_customer(url: str, method: str, path: str, **kwargs: Any) -> httpx.Response:
    return httpx.request(method, f"{url}{path}", timeout=5,
                         headers={"Authorization": f"Bearer {CUSTOMER_TOKEN}"}, **kwargs)


def marker(driver: Any, robot: str) -> tuple[str, str]:
    """The robot's marker's place and where it is drawn."""
    found = driver.find_element(By.ID, f"marker-{robot}")
    return str(found.get_attribute("data-place")), str(found.get_attribute("transform"))


def wait_until(driver: Any, check: Any) -> Any:
    return WebDriverWait(driver, WAIT_S).until(check)


class TestStaffInTheBrowser:
    def test_an_offline_with_laundry_alert_is_resolved_on_the_console(
            self, quick_server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        """robot-1 goes silent with Alice's laundry aboard: the alert appears live; the staff
        say the laundry is at base and resolve it; it is gone."""
        monkeypatch.setenv("SE_OFFLINE", "true")
        url = quick_server
        with Robot(url, "robot-1") as first, Robot(url, "robot-2"), \
                chromium(tmp_path, "staff", 1280, 900) as staff:
            log_in(staff, url, STAFF_TOKEN)
            mark(staff)
            request = as_customer(url, "POST", "/api/requests", json={"CustomerId": 1}).json()
            assert request["AssignedRobotName"] == "robot-1"
            first.fields = {**first.fields, "State": "mission.at_room", "IsInTarget": True,
                            "DetectedBeacons": [beacon(ROOM_MAC)], "WeightKg": 3.0}
            for _ in range(50):  # the scale's reading is steady after a few reports
                first.report()
                loaded = as_customer(url, "POST", f"/api/requests/{request['Id']}/confirm-loaded")
                if loaded.status_code == 200:
                    break
                time.sleep(0.2)
            assert loaded.status_code == 200, loaded.text
            first.__exit__()  # robot-1 falls silent, laundry aboard

            alert = wait_for(staff, "#alerts article.alert.critical")
            assert "robot.offline.laundry" in alert
            assert not_reloaded(staff), "the console reloaded instead of being pushed"
            Select(staff.find_element(By.CSS_SELECTOR, '#alerts select[name="LaundryAt"]')
                   ).select_by_value("base")
            click(staff, '#alerts [data-action="resolve"]')
            subscribed(staff)
            assert "No open alerts" in wait_for(staff, "#alerts .empty")

    def test_the_site_map_moves_a_robot_sent_out_without_a_reload(
            self, quick_server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        """At base both; robot-1, sent to Alice, moves onto the way to her room, then to her
        door; robot-2 with a fault is drawn in the fault colour; then the robot page stops
        robot-2 with its button."""
        monkeypatch.setenv("SE_OFFLINE", "true")
        url = quick_server
        with Robot(url, "robot-1") as first, Robot(url, "robot-2") as second, \
                chromium(tmp_path, "staff", 1280, 900) as staff:
            second.fields = {**second.fields, "BatteryPct": 34.0,
                             "Fault": {"Code": "bumper", "Message": "front bumper pressed"}}
            second.report()
            log_in(staff, url, STAFF_TOKEN)
            staff.get(f"{url}/site")
            subscribed(staff)
            mark(staff)
            place, at_base = marker(staff, "robot-1")
            assert place == "Laundry"
            assert staff.find_element(By.ID, "marker-robot-2").get_attribute(
                "data-condition") == "fault"

            as_customer(url, "POST", "/api/requests", json={"CustomerId": 1})
            wait_until(staff, lambda d: marker(d, "robot-1")[0] == "Laundry -> Room 101")
            assert marker(staff, "robot-1")[1] != at_base
            assert staff.find_element(By.ID, "marker-robot-1").get_attribute(
                "data-condition") == "moving"
            first.fields = {**first.fields, "State": "mission.at_room", "IsInTarget": True,
                            "DetectedBeacons": [beacon(ROOM_MAC)]}
            wait_until(staff, lambda d: marker(d, "robot-1")[0] == "Room 101")
            assert "mission.at_room" in wait_for(staff, "#robot-list tr#view-robot-1")
            assert not_reloaded(staff), "the site map reloaded instead of being pushed"
            assert int(staff.execute_script("return document.body.dataset.robotsMoved")) >= 2
            time.sleep(1.0)  # the marker's move is animated (0.6 s): the picture after it
            screenshot(staff, "console-site.png")

            staff.find_element(By.LINK_TEXT, "robot-2").click()
            assert "bumper" in wait_for(staff, "#robot-view")
            subscribed(staff)
            click(staff, '#robot-view [data-action="estop"]')
            assert wait_for(staff, '#robot-view[data-condition="estop"]')
            # The robot's view is re-rendered when pushed: wait on it, never hold an element.
            wait_for(staff, '[data-action="resume"]:not([disabled])')
            screenshot(staff, "console-robot.png")
