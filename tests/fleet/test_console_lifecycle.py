"""A whole laundry request in real browsers against a simulated robot (issue 29).

A real ``robotd-fleet serve``; ``robotd sim laundry-console --fleet-url`` runs one laundry
robot (the real daemon on the simulator, ``SPEED`` times real time) that reports to it with
its own token; headless chromium plays the customer (390x844) and the staff. The customer
asks for a pickup, the staff accept it on the board, the robot drives to the door, the
customer's laundry goes in its bin (the simulation's hands, ``sim/robots/laundry/hands.py``)
and she confirms; the robot takes it to base, the staff mark it washed, the robot brings it
back, she takes it out and confirms, the robot returns and she pays. Both pages show every
status as it comes, without a reload (a value set on the page's ``window`` survives).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from test_console_browser import (
    CHROMEDRIVER,
    CHROMIUM,
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

ROOT = Path(__file__).resolve().parents[2]
ROBOTD = str(Path(sys.executable).parent / "robotd")
SITE_FILE = ROOT / "sim/robots/laundry/scenarios/laundry-site.toml"
SPEED = 4.0
TRAVEL_S = 90.0
"""The longest wait for the robot between two statuses (wall seconds)."""
STAFF_TOKEN = "lifecycle-test-admin-token-0123456789"
CUSTOMER_TOKEN = "lifecycle-test-customer-1-token-0123456789"
ROBOT_TOKEN = "lifecycle-test-robot-1-token-0123456789"

pytestmark = pytest.mark.skipif(
    not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
    reason=f"needs Debian's chromium and chromium-driver ({CHROMIUM}, {CHROMEDRIVER}): "
           "scripts/bootstrap --test installs them")


def site_text() -> str:
    """The simulated site's rooms, beacons, line, customers and robots, with tokens; the
    staff accept each request themselves."""
    return ("[settings]\nAutoAccept = false\n\n" + SITE_FILE.read_text() + f"""
[[tokens]]
role = "admin"
subject = "staff"
token = "{STAFF_TOKEN}"
[[tokens]]
role = "customer"
subject = "1"
token = "{CUSTOMER_TOKEN}"
[[tokens]]
role = "robot"
subject = "laundry-1"
token = "{ROBOT_TOKEN}"
""")


@contextlib.contextmanager
def simulated_robot(tmp_path: Path, url: str) -> Iterator[subprocess.Popen[bytes]]:
    """``robotd sim laundry-console`` reporting to ``url``; returns once the robot is
    online there."""
    token_file = tmp_path / "robot.token"
    token_file.write_text(ROBOT_TOKEN + "\n")
    token_file.chmod(0o600)
    log = (tmp_path / "sim.log").open("wb")
    process = subprocess.Popen(
        [ROBOTD, "sim", "laundry-console", "--fleet-url", url, "--fleet-token-file",
         str(token_file), "--speed", str(SPEED), "--socket", str(tmp_path / "robot.sock")],
        stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.monotonic() + 60
        while _robot(url)["Status"] != "Available":
            assert process.poll() is None, (tmp_path / "sim.log").read_text()[-3000:]
            assert time.monotonic() < deadline, "the simulated robot never reported"
            time.sleep(0.2)
        yield process
    finally:
        process.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(15)
        if process.poll() is None:
            process.kill()
            process.wait(5)
        log.close()


def _robot(url: str) -> dict[str, Any]:
    response = httpx.get(f"{url}/api/robots/laundry-1",
                         headers={"Authorization": f"Bearer {STAFF_TOKEN}"}, timeout=5)
    body: dict[str, Any] = response.json()
    return body


def both_show(staff: Any, phone: Any, status: str, timeout_s: float = TRAVEL_S) -> str:
    """Wait until the board's row and the phone's card say ``status``; neither page was
    reloaded meanwhile. Returns the phone card's text."""
    card = wait_for(phone, f"article.card[data-status={status}]", timeout_s)
    wait_for(staff, f"#board tr[data-status={status}]", timeout_s)
    assert not_reloaded(phone), f"{status}: the phone page reloaded instead of being pushed"
    assert not_reloaded(staff), f"{status}: the console reloaded instead of being pushed"
    return card


def after_own_post(driver: Any) -> None:
    """A page's own form post loads it again (303): mark the new load."""
    subscribed(driver)
    mark(driver)


class TestTheWholeLifecycleInTheBrowser:
    def test_a_pickup_from_request_to_payment_with_a_simulated_robot(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        monkeypatch.setenv("SE_OFFLINE", "true")  # Selenium Manager: never download
        started = time.monotonic()
        with fleet_serve(tmp_path, site_text()) as url, simulated_robot(tmp_path, url), \
                chromium(tmp_path, "staff", 1280, 900) as staff, \
                chromium(tmp_path, "customer", 390, 844) as phone:
            log_in(staff, url, STAFF_TOKEN)
            mark(staff)
            log_in(phone, url, CUSTOMER_TOKEN)
            click(phone, '[data-action="request-pickup"]')
            wait_for(phone, "article.card[data-status=Pending]")
            after_own_post(phone)
            wait_for(staff, "#board tr[data-status=Pending]")
            assert not_reloaded(staff)

            click(staff, '#board tr[data-status=Pending] [data-action="accept"]')
            wait_for(staff, "#board tr[data-status=Accepted]")
            after_own_post(staff)
            assert "on its way to you" in both_show(staff, phone, "Accepted")

            # The robot drives to the door; the customer's laundry goes in; she confirms.
            assert "at your door" in both_show(staff, phone, "ArrivedAtRoom")
            click(phone, '[data-action="confirm-loaded"]')
            wait_for(phone, "article.card[data-status=LaundryLoaded]")
            after_own_post(phone)
            both_show(staff, phone, "LaundryLoaded")

            # At base the staff empty it and wash; then they mark it washed.
            assert "being washed" in both_show(staff, phone, "Washing")
            wait_for(staff, '#board tr[data-status=Washing] [data-action="washing-done"]')
            screenshot(staff, "console-staff.png")
            click(staff, '#board tr[data-status=Washing] [data-action="washing-done"]')
            after_own_post(staff)
            assert "on its way back" in both_show(staff, phone, "FinishedWashingGoingToRoom")

            card = both_show(staff, phone, "FinishedWashingArrivedAtRoom")
            assert "take your clean laundry" in card
            click(phone, '[data-action="confirm-unloaded"]')
            after_own_post(phone)
            both_show(staff, phone, "FinishedWashingGoingToBase")
            screenshot(phone, "console-customer.png")

            assert "Done" in both_show(staff, phone, "Completed")
            click(phone, '[data-action="pay"]')
            after_own_post(phone)
            assert "Paid" in wait_for(phone, "article.card[data-status=Completed]")
            request = httpx.get(f"{url}/api/requests", headers={
                "Authorization": f"Bearer {STAFF_TOKEN}"}).json()[0]
            assert (request["Status"], request["IsPaid"]) == ("Completed", True)
        print(f"lifecycle wall time {time.monotonic() - started:.1f} s at speed x{SPEED}")
