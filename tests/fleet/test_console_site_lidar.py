"""A RelayBot and a vacuum in simulation on the staff's site map, in a real browser (issue 29).

A real ``robotd-fleet serve`` whose site file's ``map`` is the map the RelayBot of
``delivery-fleet`` localises on (the world's walls rasterised as ``map.file = "walls"`` does,
written here from the same world) and which places the vacuum's odometry frame on it
(``odom_on_map``). Two ``robotd sim`` processes report to it over HTTP with their own tokens:
``delivery-fleet`` (snagged on its way to the warehouse: error_recovery, category ``stuck``)
and ``docking-rear`` with the dock's contacts faulty for good (the vacuum gives up docking:
``docking_gave_up``). Headless chromium holds the staff's board and site map open: both
robots' markers stand at their reported poses mapped to map pixels and move without a reload;
both faults appear on the board's alerts without a reload.

With ``ROBOTD_CONSOLE_SCREENSHOTS=DIR`` it saves ``console-site-lidar.png`` there.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import yaml
from gave_up_scenario import gave_up_scenario
from test_console_browser import (
    CHROMEDRIVER,
    CHROMIUM,
    chromium,
    fleet_serve,
    log_in,
    mark,
    not_reloaded,
    screenshot,
    subscribed,
)

from sim.nav.map_writer import write_walls_map
from sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
ROBOTD = str(Path(sys.executable).parent / "robotd")
RELAY_SPEED, VACUUM_SPEED = 4.0, 10.0
"""Times real time: RelayBot is stuck at about 94 s, the vacuum gives up at about 351 s."""
FAULT_WAIT_S = 150.0
"""The longest wait (wall seconds) for a fault to reach the board."""
ODOM_ON_MAP = (5.0, 3.0, 90.0)
"""Where the vacuum's odometry frame lies on the site map (x_m, y_m, theta_deg)."""
STAFF_TOKEN = "site-lidar-test-admin-token-0123456789"
TOKENS = {"sim-1": "site-lidar-test-sim-1-token-0123456789",
          "vac-1": "site-lidar-test-vac-1-token-0123456789"}
PIXELS = 3.0
"""How near a marker must stand to the reported pose's pixel."""

pytestmark = pytest.mark.skipif(
    not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
    reason=f"needs Debian's chromium and chromium-driver ({CHROMIUM}, {CHROMEDRIVER}): "
           "scripts/bootstrap --test installs them")


def site_text(tmp_path: Path) -> str:
    """The site: the RelayBot's map (written beside the site file), both robots, tokens."""
    scenario = load_scenario("delivery-fleet")
    resolution = float(scenario.raw["config"]["map"]["resolution_m"])
    write_walls_map(scenario.world, tmp_path, resolution)
    x, y, theta = ODOM_ON_MAP
    return f"""map = "walls.yaml"

[[robots]]
name = "sim-1"
[[robots]]
name = "vac-1"
odom_on_map = [{x}, {y}, {theta}]

[[tokens]]
role = "admin"
subject = "staff"
token = "{STAFF_TOKEN}"
""" + "".join(f"""
[[tokens]]
role = "robot"
subject = "{name}"
token = "{token}"
""" for name, token in TOKENS.items())


@contextlib.contextmanager
def simulated(tmp_path: Path, url: str, robot: str, scenario: str, speed: float,
              *extra: str) -> Iterator[subprocess.Popen[bytes]]:
    """``robotd sim SCENARIO --fleet-url URL`` for ``robot``, its own token and socket."""
    token_file = tmp_path / f"{robot}.token"
    token_file.write_text(TOKENS[robot] + "\n")
    token_file.chmod(0o600)
    log_path = tmp_path / f"{robot}.log"
    log = log_path.open("wb")
    process = subprocess.Popen(
        [ROBOTD, "sim", scenario, "--fleet-url", url, "--fleet-token-file", str(token_file),
         "--speed", str(speed), "--socket", str(tmp_path / f"{robot}.sock"), *extra],
        stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        yield process
    finally:
        process.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(15)
        if process.poll() is None:
            process.kill()
            process.wait(5)
        log.close()


def reported(url: str, robot: str) -> dict[str, Any]:
    response = httpx.get(f"{url}/api/robots/{robot}",
                         headers={"Authorization": f"Bearer {STAFF_TOKEN}"}, timeout=5)
    body: dict[str, Any] = response.json()
    return body


def until(check: Any, timeout_s: float, what: str, *logs: Path) -> Any:
    deadline = time.monotonic() + timeout_s
    while True:
        found = check()
        if found:
            return found
        if time.monotonic() > deadline:
            tails = "\n".join(f"{p.name}: {p.read_text()[-1500:]}" for p in logs if p.exists())
            pytest.fail(f"{what} (after {timeout_s:.0f} s)\n{tails}")
        time.sleep(0.2)


class SiteMapFrame:
    """The test's own reading of the map YAML and the placement: pose -> map pixel."""

    def __init__(self, yaml_path: Path, height_px: int) -> None:
        doc = yaml.safe_load(yaml_path.read_text())
        self.resolution = float(doc["resolution"])
        self.ox, self.oy = float(doc["origin"][0]), float(doc["origin"][1])
        self.height = height_px

    def pixel(self, x: float, y: float, map_name: str) -> tuple[float, float]:
        if map_name == "odom":
            px, py, deg = ODOM_ON_MAP
            c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
            x, y = px + c * x - s * y, py + s * x + c * y
        else:
            assert map_name == "walls"
        return (x - self.ox) / self.resolution, self.height - (y - self.oy) / self.resolution


def drawn_at(driver: Any, robot: str) -> tuple[float, float, dict[str, str]] | None:
    """Where the robot's marker is drawn (its translate) and the pose it carries."""
    found = driver.execute_script(
        "const g = document.getElementById('marker-' + arguments[0]);"
        "if (g === null || g.style.display === 'none') return null;"
        "return [g.getAttribute('transform'), Object.assign({}, g.dataset)];", robot)
    if found is None:
        return None
    match = re.fullmatch(r"translate\(([-\d.]+),([-\d.]+)\)", found[0])
    assert match, found[0]
    return float(match[1]), float(match[2]), found[1]


def near(frame: SiteMapFrame, at: tuple[float, float, dict[str, str]] | None,
         pose: dict[str, Any] | None) -> bool:
    """The marker stands within ``PIXELS`` of the pose's pixel."""
    if at is None or pose is None:
        return False
    want = frame.pixel(pose["X"], pose["Y"], pose["Map"])
    return math.dist(want, at[:2]) <= PIXELS


def watch_alerts(driver: Any) -> None:
    """Note the code of every alert the board shows from now on, however briefly (a fault
    that clears resolves its alert): an observer of the page's DOM, gone with a reload."""
    driver.execute_script(
        "window.alertCodes = new Set();"
        "const note = () => document.querySelectorAll('#alerts article.alert')"
        "  .forEach((a) => window.alertCodes.add(a.dataset.code));"
        "new MutationObserver(note).observe(document.body, {childList: true, subtree: true});"
        "note();")


def alert_codes(driver: Any) -> set[str]:
    """The codes of the alerts the board has shown since ``watch_alerts``."""
    return set(driver.execute_script("return Array.from(window.alertCodes || []);"))


class TestLidarRobotsOnTheSiteMap:
    def test_a_relaybot_and_a_vacuum_stand_at_their_poses_and_their_faults_are_alerts(
            self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        monkeypatch.setenv("SE_OFFLINE", "true")  # Selenium Manager: never download
        logs = (tmp_path / "sim-1.log", tmp_path / "vac-1.log", tmp_path / "fleet.log")
        with fleet_serve(tmp_path, site_text(tmp_path)) as url, \
                simulated(tmp_path, url, "sim-1", "delivery-fleet", RELAY_SPEED), \
                simulated(tmp_path, url, "vac-1", str(gave_up_scenario(tmp_path)),
                          VACUUM_SPEED, "--seed", "2"), \
                chromium(tmp_path, "staff", 1280, 1000) as staff:
            for robot in TOKENS:
                until(lambda r=robot: reported(url, r)["Pose"], 90, f"{robot} reported no pose",
                      *logs)
            log_in(staff, url, STAFF_TOKEN)
            mark(staff)
            watch_alerts(staff)
            board = staff.current_window_handle
            staff.switch_to.new_window("window")
            staff.get(f"{url}/site")
            subscribed(staff)
            mark(staff)
            svg = staff.find_element("id", "site-map")
            assert svg.get_attribute("class") == "picture"
            frame = SiteMapFrame(tmp_path / "walls.yaml", int(svg.get_attribute("data-height")))

            first = {robot: drawn_at(staff, robot) for robot in TOKENS}
            for robot, at in first.items():
                assert at is not None, f"{robot} is not drawn on the map"
                # Drawn where the pose it carries maps to, by the test's own reckoning.
                pose = {"X": float(at[2]["x"]), "Y": float(at[2]["y"]), "Map": at[2]["map"]}
                assert near(frame, at, pose), (robot, at, frame.pixel(
                    pose["X"], pose["Y"], pose["Map"]))
            # Both move, pushed: the marker follows the pose the robot reports.
            for robot in TOKENS:
                until(lambda r=robot: (drawn_at(staff, r) or (0, 0))[:2] != first[r][:2],
                      60, f"{robot}'s marker never moved", *logs)
                until(lambda r=robot: near(frame, drawn_at(staff, r),
                                           reported(url, r)["Pose"]),
                      30, f"{robot}'s marker is not at its reported pose", *logs)
            assert not_reloaded(staff), "the site map reloaded instead of being pushed"
            assert int(staff.execute_script("return document.body.dataset.robotsMoved")) >= 2
            assert not staff.find_elements("id", "no-pose")  # both are on the map


            # Each fault is an alert on the board while it lasts (RelayBot's resolves itself
            # once it is home again, perhaps before the vacuum gives up).
            staff.switch_to.window(board)
            for code in ("stuck", "docking_gave_up"):
                until(lambda c=code: c in alert_codes(staff), FAULT_WAIT_S,
                      f"the fault {code} never reached the board", *logs)
            assert not_reloaded(staff), "the board reloaded instead of being pushed"

            staff.switch_to.window(staff.window_handles[-1])
            assert not_reloaded(staff)
            for robot in TOKENS:  # both stand still now (home again; in recovery)
                until(lambda r=robot: near(frame, drawn_at(staff, r),
                                           reported(url, r)["Pose"]),
                      30, f"{robot}'s marker is not at its reported pose", *logs)
            vacuum = drawn_at(staff, "vac-1")
            assert vacuum is not None and vacuum[2]["condition"] in ("fault", "estop")
            time.sleep(1.0)  # the marker's move is animated (0.6 s): the picture after it
            screenshot(staff, "console-site-lidar.png")
