"""The dock IR device on a simulated edge port, its settings, and lgpio's batching."""

from __future__ import annotations

import asyncio
import random
import threading
from typing import Any

import pytest

from drivers.dock_ir import DockIrReceivers, from_settings
from drivers.dock_ir.config import DockIrConfig
from drivers.dock_ir.gpio_edges import LgpioIrEdges
from hal.devices import DockIr
from hal.ports import IrEdgeSource
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock
from sim.devices import ir_emitter as em

RECEIVERS = ("omni", "front_left", "rear")


def beams_stream(receiver: str, codes: list[int], t0_us: int, seed: int = 1) -> list[Any]:
    marks, _ = em.stream_marks(codes, t0_us, jitter_us=150, rng=random.Random(seed))
    return em.to_edges(marks, receiver)


class TestDevice:
    def test_implements_the_hal_protocols(self) -> None:
        """The device is a hal DockIr and the simulated port a hal IrEdgeSource."""
        source = em.SimIrEdgeSource()
        assert isinstance(DockIrReceivers(lambda: source, receivers=RECEIVERS), DockIr)
        assert isinstance(source, IrEdgeSource)

    def test_readings_show_what_each_receiver_sees_over_the_window(self) -> None:
        """Green on front_left and red on omni: each reading names them, per receiver."""
        async def main() -> Any:
            source = em.SimIrEdgeSource()
            device = DockIrReceivers(lambda: source, receivers=RECEIVERS, window_s=0.2)
            await device.start()
            now = source.now_us()
            source.push(em.merge(beams_stream("front_left", [164] * 6, now + 1000),
                                 beams_stream("omni", [168, 172] * 3, now + 9000, seed=2)))
            await asyncio.sleep(0.42)  # six frames of ~50 ms, then the gap and the flush lag
            reading = await device.next_reading()
            await device.close()
            return reading, device.status(), source

        reading, status, source = vclock.run(main())
        assert reading.codes == {"omni": {168, 172}, "front_left": {164}, "rear": frozenset()}
        assert reading.t_s >= 0.42
        assert reading.beams["omni"] == {"red_buoy", "green_buoy"}
        assert reading.sees("front_left", "green_buoy")
        assert status["total"]["codes"] == 12 and status["total"]["error_rate"] == 0
        assert source.batches < source.edges / 10  # batches, not a wake-up per edge

    def test_beams_fade_once_the_window_passes(self) -> None:
        """After the emitter stops, a reading a window later sees nothing."""
        async def main() -> Any:
            source = em.SimIrEdgeSource()
            device = DockIrReceivers(lambda: source, receivers=RECEIVERS, window_s=0.2)
            await device.start()
            source.push(beams_stream("omni", [161] * 2, source.now_us() + 1000))
            await asyncio.sleep(0.2)
            seen = device.latest()
            await asyncio.sleep(0.4)
            faded = device.latest()
            await device.close()
            return seen, faded

        seen, faded = vclock.run(main())
        assert seen is not None and seen.codes["omni"] == {161}
        assert faded is not None and faded.codes["omni"] == frozenset()

    def test_bad_signals_are_counted_not_raised(self) -> None:
        """Noise, a collision, an unknown code and a stranger's edges: counted, no exception."""
        async def main() -> Any:
            source = em.SimIrEdgeSource()
            device = DockIrReceivers(lambda: source, receivers=RECEIVERS)
            await device.start()
            t = source.now_us() + 1000
            a, _ = em.code_marks(164, t)
            b, _ = em.code_marks(168, t + 5000)
            unknown, _ = em.code_marks(77, t + 100_000)
            source.push(em.to_edges(em.union(a, b), "omni") + em.to_edges(unknown, "rear")
                        + em.to_edges(em.spikes(t, t + 50_000, 5), "front_left")
                        + em.to_edges([(t, t + 1000)], "side_left"))
            await asyncio.sleep(0.3)
            await device.close()
            return device.status()

        status = vclock.run(main())
        assert status["receivers"]["omni"]["collisions"] == 1
        assert status["receivers"]["rear"]["unknown_codes"] == 1
        assert status["receivers"]["front_left"]["glitches"] >= 1
        assert status["foreign_edges"] == 2

    def test_the_window_is_tunable(self) -> None:
        """docking.ir_window_s set on a running robot reaches the device."""
        settings = Settings(defaults())
        device = from_settings(settings, open_source=em.SimIrEdgeSource)
        settings.set("docking.ir_window_s", 0.5)
        assert device.window.window_us == 500_000


class TestSettings:
    def test_defaults_give_six_receivers_and_the_oi_table(self) -> None:
        """The default docking section: six receivers on distinct lines, OI codes."""
        cfg = DockIrConfig.from_settings(Settings(defaults()))
        assert tuple(cfg.lines) == ("omni", "front_left", "front_right", "side_left",
                                    "side_right", "rear")
        assert cfg.active_low and cfg.tolerance == 0.25 and cfg.window_s == 0.2
        assert cfg.table.beams(172) == {"red_buoy", "green_buoy"}

    def test_two_receivers_on_one_line_are_refused(self) -> None:
        """The same GPIO for two receivers names both keys."""
        values = defaults()
        values["docking"]["ir_gpio_rear"] = values["docking"]["ir_gpio_omni"]
        with pytest.raises(ValueError, match=r"ir_gpio_rear: GPIO 17 is already .*ir_gpio_omni"):
            DockIrConfig.from_settings(Settings(values))

    def test_receivers_not_fitted_are_left_out(self) -> None:
        """-1 leaves a receiver out; none at all is refused."""
        values = defaults()
        for r in ("side_left", "side_right", "rear"):
            values["docking"][f"ir_gpio_{r}"] = -1
        assert tuple(DockIrConfig.from_settings(Settings(values)).lines) == (
            "omni", "front_left", "front_right")
        for r in ("omni", "front_left", "front_right"):
            values["docking"][f"ir_gpio_{r}"] = -1
        with pytest.raises(ValueError, match="no receiver has a GPIO line"):
            DockIrConfig.from_settings(Settings(values))


class FakeLgpio:
    """lgpio's calls that the edge source makes, with alerts fired from a thread like lgpio's."""

    BOTH_EDGES = 3

    def __init__(self) -> None:
        self.callbacks: dict[int, Any] = {}
        self.claimed: list[int] = []
        self.closed = False

    def gpiochip_open(self, chip: int) -> int:
        return 7

    def gpio_claim_alert(self, handle: int, gpio: int, eflags: int) -> None:
        self.claimed.append(gpio)

    def callback(self, handle: int, gpio: int, edge: int, func: Any) -> Any:
        self.callbacks[gpio] = func
        return type("Cb", (), {"cancel": lambda _self: None})()

    def gpio_free(self, handle: int, gpio: int) -> None:
        self.claimed.remove(gpio)

    def gpiochip_close(self, handle: int) -> None:
        self.closed = True


class TestLgpioEdges:
    async def test_alerts_from_lgpios_thread_arrive_as_one_batch(self) -> None:
        """A frame's 16 alerts from another thread reach the loop as one batch, in order."""
        lg = FakeLgpio()
        source = LgpioIrEdges(0, {"omni": 17, "rear": 25}, asyncio.get_running_loop(),
                              lgpio_module=lg)
        marks, _ = em.code_marks(161, 1_000_000)
        alerts = [(e.level, e.t_us * 1000) for e in em.to_edges(marks, "omni")]

        def fire() -> None:
            for level, t_ns in alerts:
                lg.callbacks[17](0, 17, int(level), t_ns)
            lg.callbacks[25](0, 25, 2, 0)  # a watchdog report: not an edge

        thread = threading.Thread(target=fire)
        thread.start()
        thread.join()
        batch = await asyncio.wait_for(source.next_edges(), 1.0)
        source.close()
        assert [(e.level, e.t_us) for e in batch] == [(bool(lv), t // 1000) for lv, t in alerts]
        assert {e.receiver for e in batch} == {"omni"}
        assert lg.claimed == [] and lg.closed
