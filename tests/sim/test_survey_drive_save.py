"""``robotd map``'s survey on the simulated robot (the real LD19 and motor-board drivers over
their simulated byte streams): driven by ``drive`` through the control socket, stop and go,
its map saved with ``survey.save_map`` (``robotctl map save``) into the state directory's
``maps/``; the saved map is taken as it is by ``check-config``, the localiser and the planner."""

from __future__ import annotations

import asyncio
import math
import random
import tempfile
from pathlib import Path
from typing import Any

from daemon_harness import RpcClient

from behaviours.motion.odometry import Odometry
from behaviours.nav.navigator import NavStack
from behaviours.profiles.survey import SurveyProfile
from hal.occupancy_map import OCCUPIED, read_map_yaml
from hal.ports import system_wall_clock
from robotd.config import Settings, load_config
from robotd.daemon import Daemon
from sim import vclock
from sim.config import robot_settings
from sim.rig import open_sim_rig
from sim.scenario import load_scenario
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose


async def _drive(client: RpcClient, linear: float, angular: float, seconds: float) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + seconds
    while loop.time() < end:
        await client.call("drive", {"linear_mps": linear, "angular_rad_s": angular})
        await asyncio.sleep(0.2)
    await client.call("drive", {"linear_mps": 0.0, "angular_rad_s": 0.0})
    await asyncio.sleep(0.8)  # standing: a still scan for the mapping


async def _survey(workdir: Path) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any],
                                          Settings]:
    scenario = load_scenario("nav-kidnap")  # the furnished 6 x 5 m room as the world
    spec = scenario.robots[0]
    values = robot_settings(scenario, spec, None).as_dict()
    values["robot"]["profile"] = "survey"
    values["survey"].update(start_x_m=spec.x_m, start_y_m=spec.y_m,
                            start_heading_deg=math.degrees(spec.heading_rad))
    settings = Settings(values)
    loop = asyncio.get_running_loop()
    body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                         rng=random.Random(5), clock=loop.time)
    profile = SurveyProfile()
    rig = await open_sim_rig(scenario.world, body, settings, seed=5, index=0,
                             needs=profile.devices)
    daemon = Daemon(settings, rig.devices, profile, state_dir=workdir / "state",
                    socket_path=str(workdir / "control.sock"), wall_clock=system_wall_clock,
                    notify=False, handle_signals=False)
    tasks = [asyncio.create_task(rig.run()), asyncio.create_task(daemon.run())]
    try:
        await asyncio.wait_for(daemon.ready.wait(), 20)
        client = await RpcClient.connect(str(workdir / "control.sock"))
        refused = await client.call("survey.save_map", {"name": "../elsewhere"})
        for _ in range(5):  # 5 x 0.45 m east, stop and go
            await _drive(client, 0.3, 0.0, 1.5)
        await _drive(client, 0.0, 0.8, 2.0)  # turn round a little
        for _ in range(3):
            await _drive(client, 0.3, 0.0, 1.0)
        status = (await client.call("status"))["result"]
        saved = await client.call("survey.save_map", {"name": "room"})
        await client.close()
        return refused, status, saved, settings
    finally:
        daemon.request_stop()
        await asyncio.gather(tasks[1], return_exceptions=True)
        tasks[0].cancel()
        await asyncio.gather(tasks[0], return_exceptions=True)
        await rig.close()


class TestSurvey:
    def test_driven_by_hand_it_maps_and_saves_a_map_everything_reads(self) -> None:
        """Key scans grow as it is driven; ``status`` shows them; the saved map is in the
        state directory's ``maps/``, ``check-config`` passes a config naming it, and the
        localiser and planner run on it (a plan across the room)."""
        with tempfile.TemporaryDirectory(prefix="rd-") as tmp:
            workdir = Path(tmp)
            refused, status, saved, settings = vclock.run(_survey(workdir))
            assert refused["error"]["code"] == -32602  # no directory in a map's name
            mission = status["mission"]
            assert status["profile"] == "survey" and status["state"] == "idle"
            assert mission["key_scans"] >= 8
            assert mission["map_cells"][0] > 0
            result = saved["result"]
            yaml = Path(result["yaml"])
            assert yaml == workdir / "state" / "maps" / "room.yaml"
            assert yaml.with_suffix(".pgm").exists()
            grid = read_map_yaml(yaml)
            assert (grid.cells == OCCUPIED).sum() > 200

            config = workdir / "robot.toml"
            config.write_text(f'[robot]\nname = "r1"\nprofile = "patrol"\n\n[map]\n'
                              f'file = "{yaml}"\n', encoding="utf-8")
            load_config(config)  # check-config: no problem

            values = settings.as_dict()
            values["map"]["file"] = str(yaml)
            nav_settings = Settings(values)
            drive = nav_settings.section("drive")
            nav = NavStack(nav_settings, _NoMotors(), _NoLidar(), Odometry(
                drive["wheel_base_m"], drive["wheel_radius_m"], drive["ticks_per_rev"]))
            plan = nav.planner.plan((1.0, 1.8), (3.0, 1.5))
            assert plan.length_m >= 2.0
            assert nav.localiser.particles is not None


class _NoMotors:
    connected = True

    async def drive(self, _command: object) -> None: ...
    async def stop(self) -> None: ...
    def on_link_change(self, _callback: object) -> None: ...


class _NoLidar:
    stale = False

    def listen(self, _callback: object) -> Any:
        return lambda: None

    def latest(self) -> None:
        return None

    def on_stale_change(self, _callback: object) -> None: ...
