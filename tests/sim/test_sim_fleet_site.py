"""Every robot on the fleet, in the simulator (issue 29): a vacuum and a RelayBot report to the
site's fleet server (a scenario's ``[fleet]`` table, ``sim.actors.site_fleet``); a RelayBot's
error category shows as an alert there; the staff's e-stop from the server stops a robot and
their resume lets it go on."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from gave_up_scenario import gave_up_scenario

from robotd.cli import main

Events = list[dict[str, Any]]


def _run(out: Path, scenario: str) -> Events:
    assert main(["sim", scenario, "--seed", "1", "--quiet", "--report", str(out)]) == 0
    return [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def vacuum(tmp_path_factory: pytest.TempPathFactory) -> Events:
    return _run(tmp_path_factory.mktemp("docking-fleet"), "docking-fleet")


@pytest.fixture(scope="module")
def relaybot(tmp_path_factory: pytest.TempPathFactory) -> Events:
    return _run(tmp_path_factory.mktemp("delivery-fleet"), "delivery-fleet")


def _kind(events: Events, kind: str) -> Events:
    return [e for e in events if e["kind"] == kind]


def _transitions(events: Events) -> list[tuple[str, str, str]]:
    return [(e["src"], e["trigger"], e["dst"]) for e in _kind(events, "transition")]


class TestVacuumOnTheFleet:
    def test_the_server_shows_its_state_battery_and_pose(self, vacuum: Events) -> None:
        """What the staff see in GET /api/robots follows the robot: its profile, its state
        paths through the docking cycle, its battery, its odometry pose."""
        shown = _kind(vacuum, "fleet.robot")
        assert {e["profile"] for e in shown} == {"vacuum"}
        states = {e["state"] for e in shown}
        assert {"mission.cleaning", "estop", "docking.charging"} <= states
        assert any(e["battery_pct"] is not None and e["battery_pct"] < 20 for e in shown)
        poses = [e["pose"] for e in shown if e["pose"] is not None]
        assert {p["Map"] for p in poses} == {"odom"}
        assert max(math.hypot(p["X"], p["Y"]) for p in poses) > 1.0  # it moved

    def test_staff_estop_stops_it_through_its_own_estop(self, vacuum: Events) -> None:
        order = next(e for e in _kind(vacuum, "fleet.order") if e["order"] == "estop")
        assert order["code"] == 200
        estop = _kind(vacuum, "estop")[0]
        assert (estop["source"], estop["reason"]) == ("fleet", "the fleet server's EmergencyStop")
        stopped = next(e for e in _kind(vacuum, "transition") if e["dst"] == "estop")
        assert order["t"] < stopped["t"] <= order["t"] + 1.1  # at its next report
        assert any(e["estop"] for e in _kind(vacuum, "fleet.robot"))

    def test_staff_resume_lets_it_go_on(self, vacuum: Events) -> None:
        resume = next(e for e in _kind(vacuum, "fleet.order") if e["order"] == "resume")
        after = [(e["src"], e["trigger"], e["dst"]) for e in _kind(vacuum, "transition")
                 if e["t"] > resume["t"]]
        assert after[:2] == [("estop", "resume", "idle"),
                             ("idle", "start_mission", "mission.cleaning")]
        assert "docking.charging" in {dst for _src, _trigger, dst in after}
        assert len([t for t in _transitions(vacuum) if t[2] == "estop"]) == 1


class TestDockingGaveUp:
    def test_a_vacuum_that_gave_up_docking_is_an_alert_on_the_server(
            self, tmp_path: Path) -> None:
        """``docking-rear`` with the dock's contacts faulty for good (as test_sim_docking's
        long contacts fault, seed 2): the seed's retries and fallbacks spent, the robot in
        recovery with the fault dock_failed (until recovery's timeout e-stops it); on a site
        with a fleet server that is an alert the staff see, code docking_gave_up."""
        path = gave_up_scenario(tmp_path)
        out = tmp_path / "out"
        assert main(["sim", str(path), "--seed", "2", "--quiet", "--report", str(out)]) == 0
        events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
        gave_up = _kind(events, "dock.gave_up")[0]
        alerts = _kind(events, "fleet.alert")
        assert [(a["alert_kind"], a["code"], a["robot"]) for a in alerts] == [
            ("robot.fault", "docking_gave_up", "vac-1")]
        assert gave_up["t"] < alerts[0]["t"] <= gave_up["t"] + 2.1
        shown = [e for e in _kind(events, "fleet.robot") if e["fault"]]
        assert (shown[0]["state"], shown[0]["fault"]["Code"]) == ("recovery", "dock_failed")


class TestRelayBotOnTheFleet:
    def test_the_server_shows_its_map_pose_and_order(self, relaybot: Events) -> None:
        shown = _kind(relaybot, "fleet.robot")
        assert {e["profile"] for e in shown} == {"delivery"}
        assert "order 7" in {e["job"] for e in shown}
        poses = [e["pose"] for e in shown if e["pose"] is not None]
        assert poses and {p["Map"] for p in poses} == {"walls"}

    def test_its_error_category_is_an_alert(self, relaybot: Events) -> None:
        """error_recovery's category (stuck) is the robot's fault while it recovers: the
        server raised a robot.fault alert with that code, seen by the staff at once."""
        alerts = _kind(relaybot, "fleet.alert")
        assert [(a["alert_kind"], a["code"], a["robot"]) for a in alerts] == [
            ("robot.fault", "stuck", "sim-1")]
        shown = [e for e in _kind(relaybot, "fleet.robot") if e["fault"]]
        assert (shown[0]["fault"]["Code"], shown[0]["state"]) == (
            "stuck", "mission.error_recovery")
        recovery = next(e for e in _kind(relaybot, "transition")
                        if e["dst"] == "mission.error_recovery")
        assert recovery["t"] < alerts[0]["t"] <= recovery["t"] + 2.1  # a report, a look

    def test_the_mission_is_the_one_without_a_server(self, relaybot: Events) -> None:
        moves = _transitions(relaybot)
        assert ("mission.navigating_to_warehouse", "navigation_error",
                "mission.error_recovery") in moves
        assert moves[-1] == ("mission.error_recovery", "recovery_complete", "mission.waiting")


class TestAnOutsideFleetServer:
    def test_the_robots_report_to_it_and_no_staff_orders_are_played(
            self, tmp_path: Path) -> None:
        """``--fleet-url``: docking-fleet's vacuum gets that URL and its token file (``{robot}``
        its name); the scenario's in-process server and its staff orders are not started (the
        staff are people at the outside server's console)."""
        from datetime import UTC, datetime

        from sim.actors import ActorContext
        from sim.actors.site_fleet import OutsideSiteFleet, site_fleet_for
        from sim.config import robot_settings
        from sim.scenario import load_scenario

        scenario = load_scenario("docking-fleet")
        ctx = ActorContext(scenario, tmp_path, datetime(2026, 1, 1, tzinfo=UTC),
                           lambda _e: None, lambda _r, _kg: None,
                           fleet_url="http://127.0.0.1:9", fleet_token_file="/run/{robot}.token")
        fleet = site_fleet_for(ctx, [("vac-1", False)])
        assert isinstance(fleet, OutsideSiteFleet)
        assert fleet.background() == [] and fleet.people() == []
        settings = robot_settings(scenario, scenario.robots[0], None)
        fleet.configure_robot(settings)
        assert settings.get("fleet.url") == "http://127.0.0.1:9"
        assert settings.get("fleet.token_file") == "/run/vac-1.token"
