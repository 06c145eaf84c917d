"""Load check (seed section 11): loaded, overweight, unloaded, only on a steady weight."""

from __future__ import annotations

import asyncio
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.profiles.laundry.load_check import LoadCheck, LoadVerdict
from drivers.hx711 import Hx711
from hal.readings import WeightReading
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from sim import vclock
from sim.devices.hx711_model import SimHx711Lines


def _feed(check: LoadCheck, kgs: list[float], t0_s: float = 0.0, dt_s: float = 0.1) -> None:
    for i, kg in enumerate(kgs):
        check.add(WeightReading(kg, 0, t0_s + i * dt_s))


class TestLoadCheck:
    @pytest.mark.parametrize(("kg", "load", "unload"), [
        (0.0, LoadVerdict.WAIT_LOAD, LoadVerdict.UNLOADED),
        (0.5, LoadVerdict.WAIT_LOAD, LoadVerdict.WAIT_UNLOAD),
        (0.51, LoadVerdict.LOADED, LoadVerdict.WAIT_UNLOAD),
        (4.2, LoadVerdict.LOADED, LoadVerdict.WAIT_UNLOAD),
        (9.99, LoadVerdict.LOADED, LoadVerdict.WAIT_UNLOAD),
        (10.0, LoadVerdict.OVERWEIGHT, LoadVerdict.WAIT_UNLOAD),
        (25.0, LoadVerdict.OVERWEIGHT, LoadVerdict.WAIT_UNLOAD)])
    def test_verdicts_follow_the_seed_thresholds(self, kg: float, load: LoadVerdict,
                                                 unload: LoadVerdict) -> None:
        """min < w < max is loaded, w >= max overweight, w < min unloaded (min 0.5, max 10)."""
        check = LoadCheck(min_kg=0.5, max_kg=10.0)
        _feed(check, [kg] * 12)
        assert (check.check_load(), check.check_unload()) == (load, unload)

    def test_moving_weight_is_unstable(self) -> None:
        """Readings still changing by more than stable_kg give no verdict."""
        check = LoadCheck(stable_s=1.0, stable_kg=0.05)
        _feed(check, [0.0, 0.8, 1.6, 2.4, 3.2, 4.0, 4.2, 4.2, 4.2, 4.2, 4.2])
        assert check.check_load() is LoadVerdict.UNSTABLE
        _feed(check, [4.21, 4.2, 4.19, 4.2, 4.2, 4.21], t0_s=1.1)
        assert check.check_load() is LoadVerdict.LOADED

    def test_too_short_a_history_is_unstable(self) -> None:
        """Before stable_s of readings there is no verdict, however steady they are."""
        check = LoadCheck(stable_s=1.0)
        _feed(check, [4.2] * 5)
        assert check.check_load() is LoadVerdict.UNSTABLE
        assert check.weight().kg == 4.2

    def test_overweight_alert_once_per_episode(self) -> None:
        """A steady overweight load alerts once; after it is relieved, again the next time."""
        check = LoadCheck(min_kg=0.5, max_kg=10.0)
        alerts: list[float] = []
        check.on_overweight(alerts.append)
        _feed(check, [12.0] * 30)
        _feed(check, [5.0] * 30, t0_s=3.0)
        _feed(check, [11.0] * 30, t0_s=6.0)
        assert alerts == [12.0, 11.0]

    @settings(max_examples=150, deadline=None)
    @given(steps=st.lists(st.tuples(
        st.sampled_from([0.0, 4.2, 9.97, 10.0, 10.02, 12.0, float("nan")]),
        st.sampled_from([0.05, 0.1, 0.4, 1.5]),
        st.sampled_from([None, 9.0, 10.0, 11.0])), max_size=80))
    def test_alerts_as_the_check_without_its_shortcut(
            self, steps: list[tuple[float, float, float | None]]) -> None:
        """The alert check skips the spread when the newest weight is below max_kg and no
        episode is open: the alerts and the episode state are those of the full check,
        through loads around max_kg, gaps, NaN and max_kg tuned on the way."""
        class FullCheck(LoadCheck):
            def _check_alert(self) -> None:  # as it was, without the shortcut
                w = self.weight()
                over = w.stable and w.kg is not None and w.kg >= self.max_kg
                if over and not self._overweight:
                    assert w.kg is not None
                    for callback in list(self._alert_listeners):
                        callback(w.kg)
                if w.stable:
                    self._overweight = over

        checks = (LoadCheck(min_kg=0.5, max_kg=10.0), FullCheck(min_kg=0.5, max_kg=10.0))
        alerts: tuple[list[float], list[float]] = ([], [])
        for check, seen in zip(checks, alerts, strict=True):
            check.on_overweight(seen.append)
        t_s = 0.0
        for kg, dt_s, max_kg in steps:
            t_s += dt_s
            for check in checks:
                if max_kg is not None:
                    check.set_thresholds(max_kg=max_kg)
                check.add(WeightReading(kg, 0, t_s))
            assert checks[0]._overweight == checks[1]._overweight
        assert alerts[0] == alerts[1]

    def test_thresholds_are_checked_and_tunable(self) -> None:
        """min >= max is refused; tuning weight.max_kg applies to the next verdict."""
        with pytest.raises(ValueError, match=r"weight.min_kg"):
            LoadCheck(min_kg=5, max_kg=5)
        settings = Settings(defaults())
        check = LoadCheck.from_settings(None, settings)
        _feed(check, [8.0] * 12)
        assert check.check_load() is LoadVerdict.LOADED
        settings.set("weight.max_kg", 7.5)
        assert check.check_load() is LoadVerdict.OVERWEIGHT


class TestLoadCheckClosedLoop:
    def test_customer_loads_4_2_kg_then_unloads(self) -> None:
        """With the real HX711 driver on the sim chip: empty → wait; 4.2 kg → loaded at
        4.2 +- 0.05 kg; bin emptied → unloaded."""
        async def main() -> None:
            load = {"kg": 0.0}
            lines = SimHx711Lines(weight_kg=lambda: load["kg"], sps=10, rng=random.Random(4))
            hx = Hx711(lambda: lines, tare_offset=-48_213, calibration_factor=103_500.0)
            check = LoadCheck(hx, min_kg=0.5, max_kg=10.0)
            await hx.start()
            runner = asyncio.create_task(check.run())
            await asyncio.sleep(3)
            assert check.check_load() is LoadVerdict.WAIT_LOAD
            load["kg"] = 4.2
            verdict = await asyncio.wait_for(check.wait_for(LoadVerdict.LOADED), 10)
            assert verdict is LoadVerdict.LOADED
            kg = check.weight().kg
            assert kg is not None and abs(kg - 4.2) <= 0.05
            load["kg"] = 0.0
            await asyncio.wait_for(check.wait_for(LoadVerdict.UNLOADED, unload=True), 10)
            runner.cancel()
            await hx.close()

        vclock.run(main())


class TestLoadCheckFaults:
    def test_thresholds_tuned_out_of_order_are_not_applied(self) -> None:
        """weight.min_kg tuned above weight.max_kg is refused by the settings and the check
        keeps its pair (4.2 kg stays loaded, not overweight); raising max_kg first, then
        min_kg, applies both. A pair out of order given to the check directly is not taken."""
        settings = Settings(defaults())
        check = LoadCheck.from_settings(None, settings)
        _feed(check, [4.2] * 12)
        with pytest.raises(ValueError, match=r"must be below weight\.max_kg"):
            settings.set("weight.min_kg", 12.0)
        with pytest.raises(ValueError, match=r"must be above weight\.min_kg"):
            settings.set("weight.max_kg", 0.1)
        assert (check.min_kg, check.max_kg) == (0.5, 10.0)
        assert check.check_load() is LoadVerdict.LOADED
        settings.set("weight.max_kg", 20.0)
        settings.set("weight.min_kg", 12.0)
        assert (check.min_kg, check.max_kg) == (12.0, 20.0)
        assert check.check_load() is LoadVerdict.WAIT_LOAD
        assert not check.set_thresholds(min_kg=30.0)
        assert (check.min_kg, check.max_kg) == (12.0, 20.0)

    def test_a_load_cell_that_stops_answering_leaves_no_verdict(self) -> None:
        """When the HX711 stops delivering (DOUT stuck high) the weight becomes unknown
        after stale_s instead of the last loaded verdict standing; it comes back with it."""
        async def main() -> None:
            load = {"kg": 4.2}
            lines = SimHx711Lines(weight_kg=lambda: load["kg"], sps=10, rng=random.Random(4))
            hx = Hx711(lambda: lines, tare_offset=-48_213, calibration_factor=103_500.0)
            check = LoadCheck(hx, min_kg=0.5, max_kg=10.0, stale_s=2.0)
            await hx.start()
            runner = asyncio.create_task(check.run())
            await asyncio.sleep(3)
            assert check.check_load() is LoadVerdict.LOADED
            lines.disconnect()
            await asyncio.sleep(3)
            assert check.weight().kg is None and check.status()["stale"] is True
            assert check.check_load() is LoadVerdict.UNSTABLE
            assert check.check_unload() is LoadVerdict.UNSTABLE
            lines.connect()
            verdict = await asyncio.wait_for(check.wait_for(LoadVerdict.LOADED), 10)
            assert verdict is LoadVerdict.LOADED and check.stale is False
            runner.cancel()
            await hx.close()

        vclock.run(main())
