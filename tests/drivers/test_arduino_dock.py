"""The motor board's docking lines in the driver: parsing, the dock feeds, bad lines, EVAC."""

from __future__ import annotations

import asyncio

import pytest
from arduino_bench import Bench, on_bench
from hypothesis import given
from hypothesis import strategies as st
from serial_frames import frame_body

from drivers.arduino import CommandNotDelivered
from drivers.arduino.framing import Telemetry, well_formed
from drivers.arduino.telemetry import TelemetryError, interpret
from hal.devices import (
    BinSensor,
    BumperSensor,
    ContactSensor,
    DockSignalSensor,
    DockStation,
    LinkDown,
    WallSensor,
)
from hal.readings import BinLevel, Bumpers, DockContacts, DockSignal, WallDistance


class TestInterpret:
    def test_docking_lines_become_readings(self) -> None:
        """IRS, DOCK, BUMP, WALL and BIN give their readings stamped with the given time."""
        assert interpret(Telemetry("IRS", ("1023", "0")), 1.0) == DockSignal(1023, 0, 1.0)
        assert interpret(Telemetry("DOCK", ("16800",)), 1.0) == DockContacts(16800, 1.0)
        assert interpret(Telemetry("BUMP", ("0", "1")), 1.0) == Bumpers(False, True, 1.0)
        assert interpret(Telemetry("WALL", ("12",)), 1.0) == WallDistance(12.0, 1.0)
        assert interpret(Telemetry("BIN", ("100",)), 1.0) == BinLevel(100.0, 1.0)

    @pytest.mark.parametrize("line", [
        Telemetry("IRS", ("1024", "0")), Telemetry("IRS", ("-1", "5")), Telemetry("IRS", ("5",)),
        Telemetry("IRS", ("a", "5")), Telemetry("DOCK", ("-5",)), Telemetry("DOCK", ("30001",)),
        Telemetry("DOCK", ("16.8",)), Telemetry("DOCK", ()), Telemetry("BUMP", ("2", "0")),
        Telemetry("WALL", ("-1",)), Telemetry("BIN", ("101",)),
    ])
    def test_out_of_range_or_garbled_lines_raise_naming_the_kind(self, line: Telemetry) -> None:
        """Wrong field count, non-integers or values out of range: TelemetryError."""
        with pytest.raises(TelemetryError, match=line.name):
            interpret(line, 0.0)

    @given(st.lists(st.text(max_size=8), max_size=4))
    def test_any_fields_give_a_reading_or_a_telemetry_error(self, fields: list[str]) -> None:
        """Whatever the fields, an IRS line never raises anything but TelemetryError."""
        try:
            reading = interpret(Telemetry("IRS", tuple(fields)), 0.0)
        except TelemetryError:
            return
        assert isinstance(reading, DockSignal)
        assert 0 <= reading.front_left <= 1023 and 0 <= reading.front_right <= 1023

    def test_evac_is_a_well_formed_command(self) -> None:
        """EVAC:0 and EVAC:1 are contract commands; other values are not."""
        assert well_formed("EVAC:0") and well_formed("EVAC:1")
        assert not well_formed("EVAC:2") and not well_formed("EVAC")


class TestDockFeeds:
    def test_the_link_is_the_dock_station_and_its_dock_facets_are_sensors(self) -> None:
        """The link is a DockStation; link.dock's feeds fill the docking sensor Protocols."""

        async def scenario(bench: Bench) -> None:
            dock = bench.link.dock
            assert isinstance(bench.link, DockStation)
            assert isinstance(dock.signal, DockSignalSensor)
            assert isinstance(dock.contacts, ContactSensor)
            assert isinstance(dock.bumpers, BumperSensor)
            assert isinstance(dock.wall, WallSensor)
            assert isinstance(dock.bin, BinSensor)

        on_bench(scenario)

    def test_a_board_without_docking_sensors_sends_no_docking_lines(self) -> None:
        """With no source set the feeds stay empty and status() shows nothing new."""

        async def scenario(bench: Bench) -> None:
            await asyncio.sleep(2.0)
            assert bench.link.dock.signal.latest() is None
            assert "dock" not in bench.link.status()

        on_bench(scenario)

    def test_callable_sources_are_read_as_each_line_is_due(self) -> None:
        """A callable source is read at send time: the feed follows what the world says."""

        async def scenario(bench: Bench) -> None:
            strength = [300]
            bench.mcu.dock_signal = lambda: (strength[0], strength[0] // 2)
            first = await bench.link.dock.signal.next_reading()
            strength[0] = 900
            await asyncio.sleep(0.1)
            latest = bench.link.dock.signal.latest()
            assert (first.front_left, latest and latest.front_left) == (300, 900)
            assert bench.link.status()["dock"]["irs"] == [900, 450]

        on_bench(scenario)

    def test_out_of_range_lines_are_counted_as_bad_and_not_published(self) -> None:
        """IRS above 1023 and a negative DOCK are bad telemetry; the feeds keep the good ones."""

        async def scenario(bench: Bench) -> None:
            bench.mcu.contact_mv = 16_000
            await bench.link.dock.contacts.next_reading()
            bench.mcu.contact_mv = -20
            bench.mcu.dock_signal = (1500, 10)
            await asyncio.sleep(0.5)
            assert bench.link.status()["bad_telemetry"] >= 10  # 20 Hz IRS, 5 Hz DOCK
            assert bench.link.dock.signal.latest() is None
            contacts = bench.link.dock.contacts.latest()
            assert contacts is not None and contacts.mv == 16_000

        on_bench(scenario)

    def test_a_garbled_docking_line_is_counted_and_the_link_stays_up(self) -> None:
        """IRS with letters in it: counted as bad telemetry, the next good line gets through."""

        async def scenario(bench: Bench) -> None:
            bench.mcu_writes(frame_body(b"IRS:12,x"))
            bench.mcu_writes(frame_body(b"IRS:12,34"))
            reading = await asyncio.wait_for(bench.link.dock.signal.next_reading(), 1.0)
            assert (reading.front_left, reading.front_right) == (12, 34)
            assert bench.link.status()["bad_telemetry"] == 1
            assert bench.link.connected

        on_bench(scenario)

    def test_the_dock_feeds_fail_when_the_link_goes_down(self) -> None:
        """A waiter on a dock feed gets LinkDown when the board is unplugged."""

        async def scenario(bench: Bench) -> None:
            waiter = asyncio.ensure_future(bench.link.dock.bumpers.next_reading())
            await asyncio.sleep(0.1)
            bench.mcu.unplug()
            with pytest.raises(LinkDown):
                await asyncio.wait_for(waiter, 2.0)

        on_bench(scenario)


class TestEvacuate:
    def test_evacuate_sends_evac_and_the_board_records_it(self) -> None:
        """evacuate(True/False) reaches the board as EVAC:1/EVAC:0, in order."""

        async def scenario(bench: Bench) -> None:
            seen: list[bool] = []
            bench.mcu.evac_listeners.append(seen.append)
            await bench.link.evacuate(True)
            assert bench.mcu.evac
            await bench.link.evacuate(False)
            assert seen == [True, False]
            assert [on for _t, on in bench.mcu.evac_log] == [True, False]

        on_bench(scenario)

    def test_a_board_reset_turns_evac_off(self) -> None:
        """The board restarting drops its outputs: EVAC goes off and the change is recorded."""

        async def scenario(bench: Bench) -> None:
            await bench.link.evacuate(True)
            bench.mcu.reset()
            assert not bench.mcu.evac
            assert [on for _t, on in bench.mcu.evac_log] == [True, False]

        on_bench(scenario)

    def test_evacuate_on_a_board_that_refuses_it_raises(self) -> None:
        """Old firmware NAKs EVAC: evacuate raises CommandNotDelivered (a LinkDown)."""

        async def scenario(bench: Bench) -> None:
            # What a sketch without EVAC answers (the fake caches each payload's parse).
            bench.mcu._payloads[b"EVAC:1"] = ("EVAC:1", "", (), "NAK:PARSE", 0)
            with pytest.raises(CommandNotDelivered, match="EVAC:1"):
                await bench.link.evacuate(True)

        on_bench(scenario)
