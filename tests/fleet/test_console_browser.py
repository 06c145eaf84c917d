"""The console in a real browser (issue 29): a real ``robotd-fleet serve`` process, headless
Debian chromium driven by Selenium. A customer on a phone-sized page (390x844) asks for a
pickup; the staff console, open in a second browser, shows it without reloading and the staff
accept it (AutoAccept is off); the customer's page follows the change live. A robot fault
reported meanwhile appears as an alert on the console, also without reloading.

With ``ROBOTD_CONSOLE_SCREENSHOTS=DIR`` set, the test saves ``console-staff.png`` and
``console-customer.png`` there (``DIR=docs`` makes the pictures in docs/).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
from selenium.common.exceptions import StaleElementReferenceException  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

FLEET = str(Path(sys.executable).parent / "robotd-fleet")
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"  # Debian's: Selenium Manager must not download one
SCREENSHOTS = os.environ.get("ROBOTD_CONSOLE_SCREENSHOTS")
WAIT_S = 15.0

ROOM_MAC = "C3:00:00:00:01:01"
STAFF_TOKEN = "console-test-admin-token-0123456789"
CUSTOMER_TOKEN = "console-test-customer-1-token-0123456789"
ROBOT_TOKENS = {f"robot-{n}": f"console-test-robot-{n}-token-0123456789" for n in (1, 2)}
SITE = f"""
[settings]
AutoAccept = false            # the staff accept each request on the console

[[rooms]]
name = "Laundry"
[[rooms]]
name = "Room 101"

[[beacons]]
mac = "C3:00:00:00:00:01"
name = "base-1"
room = "Laundry"
base = true
[[beacons]]
mac = "C3:00:00:00:01:01"
name = "room-101"
room = "Room 101"

[[customers]]
id = 1
name = "Alice"
beacon = "C3:00:00:00:01:01"

[[robots]]
name = "robot-1"
[[robots]]
name = "robot-2"

[[tokens]]
role = "admin"
subject = "staff"
token = "{STAFF_TOKEN}"
[[tokens]]
role = "customer"
subject = "1"
token = "{CUSTOMER_TOKEN}"
""" + "".join(f"""
[[tokens]]
role = "robot"
subject = "{name}"
token = "{token}"
""" for name, token in ROBOT_TOKENS.items())

pytestmark = pytest.mark.skipif(
    not (shutil.which(CHROMIUM) and Path(CHROMEDRIVER).exists()),
    reason=f"needs Debian's chromium and chromium-driver ({CHROMIUM}, {CHROMEDRIVER}): "
           "scripts/bootstrap --test installs them")


def beacon(mac: str, rssi: int = -50) -> dict[str, Any]:
    return {"MacAddress": mac, "Uuid": "fda50693-a4e2-4fb1-afcf-c6eb07647825", "Major": 1,
            "Minor": 1, "Rssi": rssi, "Distance": 0.5}


def assigned_robot(url: str) -> str:
    """The robot of the newest request, as the API tells the staff."""
    response = httpx.get(f"{url}/api/requests",
                         headers={"Authorization": f"Bearer {STAFF_TOKEN}"})
    name: str = response.json()[0]["AssignedRobotName"]
    return name


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


@contextlib.contextmanager
def fleet_serve(tmp_path: Path, site_text: str) -> Iterator[str]:
    """A real ``robotd-fleet serve`` on a free port with this site; yields its URL."""
    site = tmp_path / "site.toml"
    site.write_text(site_text)
    port = _free_port()
    log = (tmp_path / "fleet.log").open("wb")
    process = subprocess.Popen(
        [FLEET, "serve", "--db", f"sqlite:///{tmp_path / 'fleet.db'}", "--site", str(site),
         "--port", str(port), "--log-level", "warning"],
        stdout=log, stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 30
        while True:
            assert process.poll() is None, (tmp_path / "fleet.log").read_text()
            with contextlib.suppress(httpx.HTTPError):
                if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                    break
            assert time.monotonic() < deadline, "the server did not start"
            time.sleep(0.1)
        yield url
    finally:
        process.terminate()
        process.wait(10)
        log.close()


@pytest.fixture
def server(tmp_path: Path) -> Iterator[str]:
    """A real ``robotd-fleet serve`` on a free port, with the site above."""
    with fleet_serve(tmp_path, SITE) as url:
        yield url


class Robot:
    """A robot's 1 s data exchange from a thread (it must stay online to be dispatched)."""

    def __init__(self, url: str, name: str) -> None:
        self.url, self.name = url, name
        self.fields: dict[str, Any] = {"State": "idle.at_base", "BatteryPct": 87.0}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def report(self) -> None:
        response = httpx.post(
            f"{self.url}/api/Robot/{self.name}/data-exchange",
            headers={"Authorization": f"Bearer {ROBOT_TOKENS[self.name]}"}, timeout=5,
            json={"RobotName": self.name, "Timestamp": "2026-11-29T10:00:00Z",
                  "DetectedBeacons": [], "IsInTarget": False, "WeightKg": 0.0,
                  "UltrasonicDistance": 80.0, **self.fields})
        response.raise_for_status()

    def _run(self) -> None:
        while not self._stop.wait(1.0):
            with contextlib.suppress(httpx.HTTPError):
                self.report()

    def __enter__(self) -> Robot:
        self.report()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(5)


@contextlib.contextmanager
def chromium(tmp_path: Path, name: str, width: int, height: int) -> Iterator[Any]:
    """A headless Debian chromium whose page (viewport) is ``width`` x ``height``."""
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                     "--disable-gpu", f"--user-data-dir={tmp_path / name}",
                     f"--window-size={width},{height}"):
        options.add_argument(argument)
    driver = webdriver.Chrome(options=options,
                              service=webdriver.ChromeService(executable_path=CHROMEDRIVER))
    try:
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride", {
            "width": width, "height": height, "deviceScaleFactor": 1,
            "mobile": width < 600})
        yield driver
    finally:
        driver.quit()


def log_in(driver: Any, url: str, token: str) -> None:
    driver.get(f"{url}/login")
    driver.find_element(By.ID, "token").send_keys(token)
    driver.find_element(By.CSS_SELECTOR, "form.login button").click()
    subscribed(driver)


def subscribed(driver: Any) -> None:
    """Wait until the page follows the event stream (its script says so on <body>)."""
    WebDriverWait(driver, WAIT_S).until(
        lambda d: d.execute_script("return document.body.dataset.live") == "subscribed")


def mark(driver: Any) -> None:
    """A value that only this page load holds: gone if the page is reloaded."""
    driver.execute_script("window.notReloaded = true;")


def not_reloaded(driver: Any) -> bool:
    return bool(driver.execute_script("return window.notReloaded === true;"))


def wait_for(driver: Any, css: str, timeout_s: float = WAIT_S) -> str:
    """The text of what ``css`` finds, once it is there (pushed updates replace elements:
    one replaced while read is read again)."""

    def text(d: Any) -> str | None:
        try:
            found = d.find_elements(By.CSS_SELECTOR, css)
            return str(found[0].text) if found else None
        except StaleElementReferenceException:
            return None

    found: str = WebDriverWait(driver, timeout_s).until(text)
    return found


def click(driver: Any, css: str) -> None:
    """Click what ``css`` finds, again if a pushed update replaced it meanwhile."""

    def clicked(d: Any) -> bool:
        try:
            d.find_element(By.CSS_SELECTOR, css).click()
        except StaleElementReferenceException:
            return False
        return True

    WebDriverWait(driver, WAIT_S).until(clicked)


def screenshot(driver: Any, name: str) -> None:
    if SCREENSHOTS:
        Path(SCREENSHOTS).mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(Path(SCREENSHOTS) / name))


class TestConsoleInABrowser:
    def test_a_pickup_goes_from_the_phone_to_the_console_and_back_live(
            self, server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        """The staff see the new request appear without a reload and accept it; the
        customer's phone page shows it accepted without a reload; a robot's fault appears
        as an open alert on the console without a reload. The robot reaches the door (both
        pages follow), its scale reads the laundry, and the customer confirms it loaded."""
        monkeypatch.setenv("SE_OFFLINE", "true")  # Selenium Manager: never download
        with Robot(server, "robot-1") as first, Robot(server, "robot-2") as faulty, \
                chromium(tmp_path, "staff", 1280, 900) as staff, \
                chromium(tmp_path, "customer", 390, 844) as phone:
            robots = {"robot-1": first, "robot-2": faulty}
            log_in(staff, server, STAFF_TOKEN)
            assert staff.current_url == f"{server}/"
            mark(staff)
            log_in(phone, server, CUSTOMER_TOKEN)
            assert phone.current_url == f"{server}/me"
            assert phone.execute_script("return [innerWidth, innerHeight]") == [390, 844]

            click(phone, '[data-action="request-pickup"]')
            card = wait_for(phone, "article.card[data-status=Pending]")
            assert "Waiting for the laundry room" in card
            subscribed(phone)
            mark(phone)

            row = wait_for(staff, "#board tr[data-status=Pending]")
            assert not_reloaded(staff), "the console reloaded instead of being pushed"
            assert "Alice" in row
            assert "needs approval" in row

            faulty.fields = {**faulty.fields, "BatteryPct": 41.0,
                             "Fault": {"Code": "bumper", "Message": "front bumper pressed"}}
            alert = wait_for(staff, "#alerts article.alert")
            assert "robot.fault" in alert
            assert not_reloaded(staff)

            click(staff, '#board tr[data-status=Pending] [data-action="accept"]')
            accepted = wait_for(staff, "#board tr[data-status=Accepted]")
            assert "robot-" in accepted
            subscribed(staff)  # the form's post loaded the console again: mark this load
            mark(staff)

            card = wait_for(phone, "article.card[data-status=Accepted]")
            assert not_reloaded(phone), "the phone page reloaded instead of being pushed"
            assert "on its way to you" in card
            assert phone.find_elements(By.CSS_SELECTOR, '[data-action="cancel"]')
            assert not phone.find_elements(By.CSS_SELECTOR, '[data-action="pay"]')

            assert "robot-" in wait_for(staff, "#robots tr[data-status=Busy]")
            screenshot(staff, "console-staff.png")
            screenshot(phone, "console-customer.png")

            # The robot reaches the customer's door; then its scale reads the laundry.
            robot = robots[assigned_robot(server)]
            robot.fields = {**robot.fields, "State": "mission.at_room", "IsInTarget": True,
                            "DetectedBeacons": [beacon(ROOM_MAC)], "WeightKg": 0.0}
            card = wait_for(phone, "article.card[data-status=ArrivedAtRoom]")
            assert "at your door" in card
            assert "the button appears when its scale reads it" in card
            assert not phone.find_elements(By.CSS_SELECTOR, '[data-action="confirm-loaded"]')
            wait_for(staff, "#board tr[data-status=ArrivedAtRoom]")
            robot.fields = {**robot.fields, "WeightKg": 3.0}
            click(phone, '[data-action="confirm-loaded"]')
            card = wait_for(phone, "article.card[data-status=LaundryLoaded]")
            assert "on its way to the laundry room" in card
            assert phone.find_elements(By.CSS_SELECTOR, '[data-action="pay"]')
            assert not_reloaded(staff), "the console reloaded instead of being pushed"

    def test_the_event_stream_takes_the_session_cookie(self, server: str) -> None:
        """GET /api/events with a console session (no bearer token) streams; a cookie that
        is no session is 401."""
        with httpx.Client(base_url=server, follow_redirects=False) as client:
            form = client.get("/login")
            csrf = form.text.split('name="csrf" value="')[1].split('"')[0]
            assert client.post("/login", data={"csrf": csrf, "token": STAFF_TOKEN}
                               ).status_code == 303
            with client.stream("GET", "/api/events") as stream:
                assert stream.status_code == 200
                assert next(stream.iter_lines()) == ": subscribed"
        refused = httpx.get(f"{server}/api/events", cookies={"fleet_session": "nope"})
        assert refused.status_code == 401
