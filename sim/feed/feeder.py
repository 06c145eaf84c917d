"""The feeder: a scenario's first robot's simulated hardware, served for ``robotd run``."""

from __future__ import annotations

import asyncio
import json
import random
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TextIO

from drivers.hx711 import Gain
from robotd.profiles import PROFILES
from sim.actors import ActorContext, SimActors, actors_factory
from sim.config import robot_settings
from sim.console import SimConsole
from sim.devices.camera_model import SimCamera
from sim.devices.motor_board.pty_mcu import PtyMcu
from sim.feed.config_file import hardware_keys, write_config
from sim.feed.ports import LinePipe, PtyLine, advert_writer, pipe_conversions, pipe_edges
from sim.feed.state_watch import StateWatch
from sim.feed.videos import first_qr_payload, write_qr_video, write_still_video
from sim.registry import slice_of
from sim.rig import SimRig, open_sim_rig
from sim.scenario import Scenario, load_scenario
from sim.script import ScriptPlayer
from sim.world.body import DiffDriveBody
from sim.world.geometry import Pose

CONFIG_NAME = "robotd.toml"


@dataclass
class Feeder:
    """What one feeder serves, and what it opened (closed by ``close``)."""

    scenario: Scenario
    work: Path
    seed: int = 0
    events: TextIO | None = None
    rig: SimRig | None = None
    actors: SimActors | None = None
    mcu: PtyMcu | None = None
    lidar: PtyLine | None = None
    pipes: dict[str, LinePipe] = field(default_factory=dict)
    """The named pipes served: ``ir`` (dock IR edges), ``ble`` (adverts), ``hx711``."""
    scanners: list[Any] = field(default_factory=list)
    tasks: list[asyncio.Task[Any]] = field(default_factory=list)

    @property
    def config_path(self) -> Path:
        return self.work / CONFIG_NAME

    def record(self, event: dict[str, Any]) -> None:
        """An actor's or the script's event, one JSON line in ``feed-events.jsonl``."""
        if self.events is not None:
            t_s = asyncio.get_running_loop().time()
            self.events.write(json.dumps({"t": round(t_s, 3), **event}, default=str) + "\n")
            self.events.flush()

    async def open(self) -> Path:
        """Build the world and the devices, serve them, write the config; its path."""
        loop = asyncio.get_running_loop()
        scenario, work = self.scenario, self.work
        spec = scenario.robots[0]
        settings = robot_settings(scenario, spec, None)
        profile_name = settings.get("robot.profile")
        self.events = (work / "feed-events.jsonl").open("w")
        body = DiffDriveBody(scenario.world, Pose(spec.x_m, spec.y_m, spec.heading_rad),
                             spec.body, rng=random.Random(f"{self.seed}:{spec.name}:body"),
                             payload_kg=spec.payload_kg, clock=loop.time)
        factory = actors_factory(profile_name)
        if factory is not None:
            context = ActorContext(scenario, work, datetime.now(UTC), self.record,
                                   lambda _robot, kg: setattr(body, "payload_kg", kg))
            self.actors = factory(context)
        if self.actors is not None:
            await self.actors.start()
            self.actors.configure_robot(settings)
        devices = tuple(PROFILES.build(profile_name).devices)
        self.rig = rig = await open_sim_rig(scenario.world, body, settings, seed=self.seed,
                                            index=0, needs=devices, own=slice_of(profile_name))
        if self.actors is not None:
            self.actors.attach(rig)
        self.mcu = PtyMcu(rig.mcu, link=work / "ttyMCU")
        await self.mcu.start()
        if rig.ld19 is not None:
            self.lidar = PtyLine(work / "ttyLIDAR")
            await self.lidar.open()
            rig.ld19.connect_pipe(self.lidar)
        keys = {**await self._serve_pipes(rig), **self._write_videos(rig, devices)}
        keys.update(hardware_keys(work, mcu_port=work / "ttyMCU",
                                  lidar_port=self.lidar.link if self.lidar else None))
        write_config(self.config_path, settings, keys)
        return self.config_path

    async def _serve_pipes(self, rig: SimRig) -> dict[str, Any]:
        """A named pipe for each device that has one; the config keys that name them."""
        keys: dict[str, Any] = {}
        if rig.dock_ir is not None:
            self.pipes["ir"] = LinePipe(self.work / "dock-ir.fifo")
            keys.update({"docking.ir_source": "stream",
                         "docking.ir_stream": str(self.pipes["ir"].path)})
        if rig.air is not None:  # a scanner on the simulated air, its adverts into the pipe
            self.pipes["ble"] = LinePipe(self.work / "ble.fifo")
            scanner = rig.air.scanner_factory()(advert_writer(self.pipes["ble"]))
            await scanner.start()
            self.scanners.append(scanner)
            keys.update({"ble.source": "stream", "ble.stream": str(self.pipes["ble"].path)})
        if rig.hx711_lines is not None:
            self.pipes["hx711"] = LinePipe(self.work / "hx711.fifo")
            keys.update({"hx711.source": "stream",
                         "hx711.stream": str(self.pipes["hx711"].path)})
        return keys

    def _write_videos(self, rig: SimRig, devices: tuple[str, ...]) -> dict[str, Any]:
        """The cameras' video files; the config keys that name them."""
        keys: dict[str, Any] = {}
        settings = rig.settings
        if isinstance(rig.devices.camera, SimCamera):  # what the camera sees at the start
            frame = rig.devices.camera.render(rig.body.pose)
            video = write_still_video(self.work / "camera.avi", frame,
                                      fps=settings.get("camera.fps"))
            keys.update({"camera.source": "file", "camera.file": str(video),
                         "camera.loop": True})
        payload = first_qr_payload(self.scenario.world)
        if "qr" in devices and payload is not None:
            video = write_qr_video(
                self.work / "qr.avi", payload, width_px=settings.get("qr_camera.width"),
                height_px=settings.get("qr_camera.height"), fps=settings.get("qr_camera.fps"))
            keys.update({"qr_camera.source": "file", "qr_camera.file": str(video),
                         "qr_camera.loop": True})
        return keys

    async def run(self, hold_s: float = 0.0) -> None:
        """Serve until cancelled: the rig's own tasks, the IR pipe, the people and the script
        (its ``when_state`` steps wait for the daemon's state, read from its socket). The
        script's clock starts ``hold_s`` after the daemon first answers."""
        assert self.rig is not None
        console = SimConsole(quiet=True)
        name = self.scenario.robots[0].name
        answered = asyncio.Event()
        player: ScriptPlayer | None = None

        def changed() -> None:
            answered.set()
            if player is not None:
                player.state_changed()

        watch = StateWatch(self.work / "control.sock", changed)
        player = ScriptPlayer(self.scenario, {name: self.rig}, self.record, console,
                              state_of=lambda _robot: watch.state)

        async def script(player: ScriptPlayer) -> None:
            await answered.wait()
            await asyncio.sleep(hold_s)
            self.record({"kind": "feed.script_started", "hold_s": hold_s})
            await player.run()

        coros: list[Any] = [self.rig.run(), script(player), watch.run()]
        if "ir" in self.pipes and self.rig.dock_ir is not None:
            coros.append(pipe_edges(self.rig.dock_ir, self.pipes["ir"]))
        if "hx711" in self.pipes and self.rig.hx711_lines is not None:
            gain = Gain[self.rig.settings.get("hx711.gain")]
            coros.append(pipe_conversions(self.rig.hx711_lines, self.pipes["hx711"], gain))
        if self.actors is not None:
            coros += [coro for _, coro in (*self.actors.people(), *self.actors.background())]
        self.tasks = [asyncio.create_task(c) for c in coros]
        await asyncio.gather(*self.tasks)

    async def close(self) -> dict[str, Any]:
        """Stop and close everything; what the devices did (for the bench's log)."""
        for task in self.tasks:
            task.cancel()
        await asyncio.gather(*self.tasks, return_exceptions=True)
        figures: dict[str, Any] = {}
        if self.rig is not None and self.rig.ld19 is not None:
            figures["ld19_bytes"] = self.rig.ld19.bytes_sent
        for scanner in self.scanners:
            await scanner.stop()
        for name, pipe in self.pipes.items():
            figures.update({f"{name}_written": pipe.written, f"{name}_dropped": pipe.dropped})
        if self.mcu is not None:
            figures["mcu_commands"] = len(self.mcu.mcu.executed)
            await self.mcu.close()
        if self.lidar is not None:
            self.lidar.break_()
        if self.actors is not None:
            await self.actors.close()
        if self.rig is not None:
            await self.rig.close()
        if self.events is not None:
            self.events.close()
        return figures


def feeder_for(scenario: str, work: Path, seed: int = 0) -> Feeder:
    """A feeder of ``scenario`` (a built-in name or a path) working in ``work``."""
    return Feeder(load_scenario(scenario), work, seed)
