"""The simulated hardware of one robot: fakes at the lowest layer, the real drivers on top.

The motor board is a ``FakeMcu`` (or the real firmware in simavr) behind an in-memory serial
port; the real ``ArduinoLink`` driver opens it. Sensor models for the camera, BLE and the HX711
are added when the robot's profile uses those devices.
"""

from __future__ import annotations

import asyncio
import random
import tempfile
from pathlib import Path
from typing import Any

import structlog

from drivers import ble_scanner, hx711
from drivers.arduino.link import ArduinoLink
from drivers.arduino.telemetry import DockFacets
from drivers.serial_port import open_serial
from hal.backend import Devices
from robotd.config.settings import Settings
from sim.devices.ble_model import BleAirParams, SimBleAir
from sim.devices.camera_model import CameraMount, SimCamera
from sim.devices.dock_ir_model import SimDockIr, dock_signal
from sim.devices.hx711_model import SimHx711Lines
from sim.devices.ld19 import SimLd19
from sim.devices.motor_board.dock_inputs import DockInputs
from sim.devices.motor_board.encoder_fault import freezable
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.devices.motor_board.simavr_bridge import SimavrBridge
from sim.devices.motor_board.simavr_mcu import SimavrMcu, SimavrUnavailable, missing_toolchain
from sim.devices.sim_serial import SimSerialPorts
from sim.nav.map_writer import write_walls_map
from sim.scenario import ScenarioError, scenario_dir
from sim.slice import SimSlice
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import World
from sim.world.lidar_rays import LidarRays

log = structlog.get_logger(__name__)


class SimRig:
    """One robot's simulated hardware, and the bench switches the scenario script uses."""

    def __init__(self, world: World, body: DiffDriveBody, settings: Settings, *, seed: int,
                 index: int, mcu: str = "fake", needs: tuple[str, ...] = (),
                 own: SimSlice | None = None) -> None:
        self.world = world
        self.body = body
        self.settings = settings
        self.mcu_kind = mcu
        self.simavr: SimavrMcu | None = None
        self.bridge: SimavrBridge | None = None
        self.mcu = FakeMcu(body, seed=seed * 1000 + index)
        self.ports = SimSerialPorts(seed=seed * 1000 + index)
        self.ports.attach(settings.get("serial.port"), self.mcu)
        self.link = ArduinoLink.from_settings(self.ports, settings)
        self.devices = Devices(
            motors=self.link, encoders=self.link.encoders, front_range=self.link.front_range,
            battery=self.link.battery, servo=self.link, leds=self.link,
        )
        self._models: list[Any] = []
        self.air: SimBleAir | None = None
        self.hx711_lines: SimHx711Lines | None = None
        self.dock_ir: SimDockIr | None = None
        rng_key = f"{seed}:{index}"
        if "camera" in needs:
            mount = CameraMount(width_px=settings.get("camera.width"),
                                height_px=settings.get("camera.height"),
                                fps=settings.get("camera.fps"))
            self.devices.camera = SimCamera(world, body, mount, seed=seed * 1000 + index)
        if "beacons" in needs:
            self.air = SimBleAir(body, rng=random.Random(f"{rng_key}:ble"),
                                 params=BleAirParams(
                                     path_loss_exponent=settings.get("ble.path_loss_exponent")))
            self.devices.beacons = ble_scanner.from_settings(settings, self.air.scanner_factory())
        if "load_cell" in needs:
            lines = SimHx711Lines.on_body(
                body, rng=random.Random(f"{rng_key}:hx711"), sps=settings.get("hx711.sps"),
                offset_counts=settings.get("hx711.tare_offset"),
                counts_per_kg=settings.get("hx711.calibration_factor"),
                clock=asyncio.get_running_loop().time)
            self.hx711_lines = lines
            self.devices.load_cell = hx711.from_settings(settings, lambda: lines)
        if "dock_ir" in needs:
            # The real driver on the receivers' simulated GPIO lines (only the fitted ones).
            from drivers.dock_ir import DockIrConfig
            from drivers.dock_ir import from_settings as dock_ir_from_settings

            fitted = DockIrConfig.from_settings(settings).lines
            source = SimDockIr(body, receivers=tuple(fitted),
                               rng=random.Random(f"{rng_key}:dock_ir"))
            self.dock_ir = source
            self.devices.dock_ir = dock_ir_from_settings(settings, lambda: source)
            self.wire_dock_inputs(self.mcu)  # the board's docking lines (a DockInputs)
            self._fill_dock_slots()
        self.ld19: SimLd19 | None = None
        self.rays: LidarRays | None = None
        self.map_dir: tempfile.TemporaryDirectory[str] | None = None
        if "lidar" in needs:
            self._fit_lidar(seed * 1000 + index)
        own = own or SimSlice(scenarios=None)
        if own.fit_devices is not None:  # devices only this robot has
            own.fit_devices(self.devices, world, body, settings, needs, seed * 1000 + index)
        self._deadman_seen = 0
        for key in own.scenario_files:  # named beside the scenario
            if not Path(settings.get(key)).expanduser().is_absolute():
                settings.set(key, str(scenario_dir(str(settings.source)) / settings.get(key)))

    def _fill_dock_slots(self) -> None:
        """A docking robot's motor-board senses: the link's docking facets, the link itself
        as the station (EVAC)."""
        facets = self.link.dock
        self.devices.dock_signal = facets.signal
        self.devices.dock_contacts = facets.contacts
        self.devices.bumpers = facets.bumpers
        self.devices.wall = facets.wall
        self.devices.bin = facets.bin
        self.devices.station = self.link

    def _fit_lidar(self, seed: int) -> None:
        """A ``SimLd19`` on ``lidar.port``, its beams cast in the world, the real driver on top;
        ``map.file = "walls"``: the world's mapped walls written as the robot's map file."""
        from drivers.lidar import Ld19Lidar, LidarConfig

        config = LidarConfig.from_settings(self.settings)
        loop = asyncio.get_running_loop()
        self.rays = LidarRays(self.world, self.body, mount_x_m=config.mount_x_m,
                              mount_y_m=config.mount_y_m, mount_yaw_rad=config.mount_yaw_rad,
                              clock=loop.time)
        self.ld19 = SimLd19(self.rays, model=config.model.value, max_range_m=config.max_range_m,
                            chunk_s=0.02, seed=seed)
        self.ports.attach(config.port, self.ld19)
        self.devices.lidar = Ld19Lidar(self.ports, config)
        if self.settings.get("map.file") == "walls":
            self.map_dir = tempfile.TemporaryDirectory(prefix="robotd-sim-map-")
            path = write_walls_map(self.world, Path(self.map_dir.name),
                                   self.settings.get("map.resolution_m"))
            self.settings.set("map.file", str(path))
        elif not Path(self.settings.get("map.file")).expanduser().is_absolute():
            # A scenario names its robot's map relative to itself, as its world.map.
            path = scenario_dir(str(self.settings.source)) / self.settings.get("map.file")
            self.settings.set("map.file", str(path))

    async def open_simavr(self) -> None:
        """Put the real firmware, in an emulated ATmega328P, on the body instead of the fake.

        The emulator runs in wall time, so this needs a wall-clock loop (``--realtime``).
        The real Arduino driver opens the emulator's UART pseudo-terminal like /dev/ttyACM0.
        """
        self.simavr = await SimavrMcu.start()
        self.bridge = SimavrBridge(self.simavr, self.body, dock=self.mcu)
        self.settings.set("serial.port", self.simavr.uart_path)
        self.link = ArduinoLink.from_settings(open_serial, self.settings)
        fill = {"motors": self.link, "encoders": self.link.encoders,
                "front_range": self.link.front_range, "battery": self.link.battery,
                "servo": self.link, "leds": self.link}
        for slot, device in fill.items():
            setattr(self.devices, slot, device)
        if self.devices.dock_ir is not None:
            self._fill_dock_slots()

    async def run(self) -> None:
        """What the simulated hardware does on its own: beacons advertising, the emulator."""
        async with asyncio.TaskGroup() as group:
            if self.air is not None:
                group.create_task(self.air.run())
            if self.bridge is not None:
                group.create_task(self.bridge.run())

    async def close(self) -> None:
        await self.mcu.close()
        if self.ld19 is not None:
            self.ld19.close()
        if self.map_dir is not None:
            self.map_dir.cleanup()
        if self.simavr is not None:
            await self.simavr.close()

    @property
    def dock_inputs(self) -> DockInputs:
        """Where the world puts what the motor board's docking sensors measure and reads EVAC
        (``dock_signal``, ``contact_mv``, ``bumpers``, ``wall_cm``, ``bin_pct``, ``evac``,
        ``evac_listeners``); the same for the fake board and the emulated firmware."""
        return self.mcu

    @property
    def dock(self) -> DockFacets:
        """The driver's docking facets (``signal``, ``contacts``, ``bumpers``, ``wall``,
        ``bin``); the link itself is the ``DockStation`` (``evacuate``)."""
        return self.link.dock

    @property
    def board(self) -> FakeMcu | SimavrMcu:
        """The motor board the bench switches act on."""
        return self.simavr if self.simavr is not None else self.mcu

    def new_deadman_stops(self) -> list[tuple[float, float | None]]:
        """Deadman stops since the last call: (time, when the last MOTOR/HB had arrived).

        Only the fake board reports them; the emulated one shows them on its pins."""
        if self.simavr is not None:
            return []
        stops = self.mcu.deadman_stops[self._deadman_seen:]
        self._deadman_seen = len(self.mcu.deadman_stops)
        return [(t, self.mcu.last_drive_s) for t in stops]

    def dock_values(self) -> dict[str, object]:
        """What the vacuum's motor board reads from the world now (its new telemetry):
        ``irs`` (front_left, front_right 0-1023), ``dock_mv``, ``bump`` (left, right),
        ``wall_cm``, ``bin_pct``. The fake MCU is wired to these when it reports them."""
        body = self.body
        return {"irs": self._irs(), "dock_mv": body.contact_mv(),
                "bump": body.bumpers(), "wall_cm": body.wall_cm(), "bin_pct": body.bin_pct}

    def wire_dock_inputs(self, board: Any) -> None:
        """Feed a motor board's docking inputs from the world, and its EVAC to the station.

        ``board`` has the sources of ``sim.devices.motor_board.dock_inputs`` (each a
        value or a callable read when its line is due) and ``evac_listeners``."""
        body = self.body
        board.dock_signal = self._irs
        board.contact_mv = body.contact_mv
        board.bumpers = body.bumpers
        board.wall_cm = body.wall_cm
        board.bin_pct = lambda: body.bin_pct
        board.evac_listeners.append(self._evac)

    def _irs(self) -> tuple[int, int]:
        """The front receivers' strength; 0 from a receiver whose cable is out."""
        left, right = dock_signal(self.body)
        out = self.dock_ir.unplugged if self.dock_ir is not None else frozenset()
        return (0 if "front_left" in out else left, 0 if "front_right" in out else right)

    def _evac(self, on: bool) -> None:
        """EVAC, signalled through the contacts: the station's suction follows it."""
        self.body.sync()  # the bin up to now under the old state
        if self.world.dock is not None:
            self.world.dock.suction = on

    # -- bench switches for the scenario script -----------------------------------------------
    def unplug_mcu(self) -> None:
        self.board.unplug()

    def replug_mcu(self) -> None:
        self.board.replug()

    def corrupt_mcu(self, pct: float) -> None:
        self.board.corrupt(pct)

    def reset_mcu(self) -> None:
        self.board.reset()

    def freeze_encoders(self, frozen: bool) -> None:
        """The fake board's encoder counters stop (``True``) or run again: the wheels turn on."""
        if self.simavr is not None:
            msg = "encoders.fail: only the fake motor board (not --mcu simavr)"
            raise ScenarioError(msg)
        plant = self.mcu.plant = freezable(self.mcu.plant)
        if frozen:
            plant.freeze()
        else:
            plant.restore()


async def open_sim_rig(world: World, body: DiffDriveBody, settings: Settings, *, seed: int,
                       index: int, mcu: str = "fake", needs: tuple[str, ...] = (),
                       own: SimSlice | None = None) -> SimRig:
    """One robot's simulated hardware (``own``: its robot's simulator slice, for the devices
    and files only it has); ``mcu="simavr"`` runs the real firmware (wall time)."""
    if mcu not in ("fake", "simavr"):
        msg = f"--mcu {mcu}: expected fake or simavr"
        raise ValueError(msg)
    rig = SimRig(world, body, settings, seed=seed, index=index, mcu=mcu, needs=needs, own=own)
    if mcu == "simavr":
        if getattr(asyncio.get_running_loop(), "virtual", False):
            msg = "--mcu simavr: the emulator runs in wall time; add --realtime"
            raise ValueError(msg)
        why = missing_toolchain()
        if why is not None:
            msg = f"--mcu simavr: {why}"
            raise ValueError(msg)
        try:
            await rig.open_simavr()
        except SimavrUnavailable as exc:
            msg = f"--mcu simavr: {exc}"
            raise ValueError(msg) from exc
    return rig
