"""robotctl for the robots' own methods against a running daemon: ``links`` and
``reset-links`` (the cabinet robot's node graph), ``status`` with the delivery robot's order."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from daemon_harness import running_daemon
from test_robotctl import robotctl

from behaviours.context import RobotContext
from behaviours.motion.odometry import Odometry
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.ctl_commands import LINKS_METHOD, RESET_METHOD
from behaviours.profiles.cabinet.map_reader import parse_site_map
from behaviours.profiles.cabinet.profile import CabinetProfile
from behaviours.profiles.cabinet.site import build_site
from behaviours.profiles.cabinet.steps.mission import Mission
from behaviours.profiles.cabinet.task_list import parse_task_list
from behaviours.profiles.delivery.memory import DELIVERY_MISSION, DeliveryMemory
from behaviours.profiles.delivery.profile import DeliveryProfile
from behaviours.service import Service
from robotd.ctl import _request as ctl_request
from robotd.ctl import build_parser
from sim.robots.cabinet.checks import cabinet_figures

EXAMPLES = Path(__file__).parents[2] / "behaviours" / "profiles" / "cabinet" / "examples"
DOOR = ["door:ab:a", "door:ab:b"]


class MappedCabinet(CabinetProfile):
    """The cabinet profile with its example map read and no devices: it stays idle."""

    def services(self, ctx: RobotContext) -> list[Service]:
        config = CabinetConfig()
        site_map = parse_site_map(json.loads((EXAMPLES / "site.json").read_text()), "site.json")
        tasks = parse_task_list(json.loads((EXAMPLES / "tasks.json").read_text()),
                                "tasks.json", site_map)
        self.mission = Mission(config, Odometry(0.3, 0.035, 1000))
        self.mission.site = build_site(site_map, tasks, config, "site.json")
        self.mission.remaining = list(tasks.tasks)
        return []


class OrderOnly(DeliveryProfile):
    """The delivery profile with its order memory and no devices: it stays idle."""

    def services(self, ctx: RobotContext) -> list[Service]:
        self.memory = DeliveryMemory(ctx.persisted(DELIVERY_MISSION))
        return []


def test_links_and_reset_links_call_the_cabinet_methods() -> None:
    """robotctl links is cabinet.links, reset-links is cabinet.reset_links, no params."""
    assert ctl_request(build_parser().parse_args(["links"])) == (LINKS_METHOD, {})
    assert ctl_request(build_parser().parse_args(["reset-links"])) == (RESET_METHOD, {})


async def test_links_shows_the_broken_link_and_reset_links_opens_it(
        capsys: pytest.CaptureFixture[str]) -> None:
    """A broken link is listed first and BROKEN; reset-links opens it; --json is the reply."""
    profile = MappedCabinet()
    async with running_daemon(profile=profile) as daemon:
        sock = str(daemon.socket_path)
        assert profile.mission is not None and profile.mission.site is not None
        graph = profile.mission.site.graph
        assert graph.break_link(*DOOR)
        code, text, _ = await robotctl(capsys, "--socket", sock, "links")
        jcode, raw, _ = await robotctl(capsys, "--socket", sock, "--json", "links")
        rcode, reset, _ = await robotctl(capsys, "--socket", sock, "reset-links")
        after_code, after, _ = await robotctl(capsys, "--socket", sock, "links")
        again_code, again, _ = await robotctl(capsys, "--socket", sock, "reset-links")
        events = list(daemon.events)
    assert code == jcode == rcode == after_code == again_code == 0
    assert "broken: door:ab:a - door:ab:b" in text
    assert any(line.split()[:2] == DOOR and line.split()[-1] == "BROKEN"
               for line in text.splitlines())
    assert json.loads(raw)["broken"] == [DOOR]
    assert "opened 1 broken link " in reset
    assert "broken: none" in after and "BROKEN" not in after
    assert "nothing to open" in again
    assert not graph.broken and graph.resets_this_task == 0
    figures = cabinet_figures([*events, {"kind": "fit.tried"}])
    assert figures["links_reset"] == 0 and figures["links_reset_by_hand"] == 2


async def test_links_before_the_map_is_read_exit_1_with_the_reason(
        capsys: pytest.CaptureFixture[str]) -> None:
    """The cabinet profile before its map is read: refused, exit 1, the reason printed."""
    class Unmapped(CabinetProfile):
        def services(self, ctx: RobotContext) -> list[Service]:
            return []

    async with running_daemon(profile=Unmapped()) as daemon:
        code, _, err = await robotctl(capsys, "--socket", str(daemon.socket_path), "links")
    assert code == 1
    assert "the map is not read yet" in err


def test_a_robot_reset_counts_apart_from_a_reset_by_hand() -> None:
    """links_reset counts the robot's own reset_links; a technician's is links_reset_by_hand."""
    events: list[dict[str, Any]] = [{"kind": "fit.tried"},
                                    {"kind": "links.reset", "opened": 2, "resets": 1},
                                    {"kind": "links.reset", "opened": 1, "by": "control"}]
    figures = cabinet_figures(events)
    assert (figures["links_reset"], figures["links_reset_by_hand"]) == (1, 1)


async def test_status_of_the_delivery_robot_shows_its_order(
        capsys: pytest.CaptureFixture[str]) -> None:
    """mission.* rows: no order as '-', then the verified order and its customer."""
    profile = OrderOnly()
    async with running_daemon(profile=profile) as daemon:
        sock = str(daemon.socket_path)
        _, before, _ = await robotctl(capsys, "--socket", sock, "status")
        assert profile.memory is not None
        await profile.memory.verified(7, 1.5, -2.25)
        await profile.memory.loaded()
        code, after, _ = await robotctl(capsys, "--socket", sock, "status")
        _, raw, _ = await robotctl(capsys, "--socket", sock, "--json", "status")
    assert code == 0
    rows = {line.split()[0]: line.split(maxsplit=1)[1] for line in before.splitlines()
            if line.startswith("mission.")}
    assert rows["mission.order_id"] == "-" and rows["mission.parcel_in_box"] == "False"
    assert rows["mission.box_angle_deg"] == "-" and rows["mission.last_error"] == "-"
    assert "mission.order_id       7" in after
    assert "mission.customer       [1.5, -2.25]" in after
    assert "mission.parcel_in_box  True" in after
    assert json.loads(raw)["mission"]["order_id"] == 7
