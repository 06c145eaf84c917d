"""The firmware's docking additions on the emulated board: the 4051's inputs, EVAC's pin."""

from __future__ import annotations

from firmware_client import PtyLink

from sim.devices.motor_board.simavr_mcu import SimavrMcu


async def fields(link: PtyLink, prefix: str) -> list[int]:
    return [int(f) for f in (await link.telemetry_matching(prefix)).split(":")[1].split(",")]


class TestDockingInputs:
    async def test_each_mux_input_comes_back_as_its_line(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """Strength counts, contact mV, bumpers, wall cm and bin % read through the 4051."""
        await mcu.set_dock_signal(700, 33)
        await mcu.set_contact_mv(14_000)
        await mcu.set_bumpers(False, True)
        await mcu.set_wall_cm(20)
        await mcu.set_bin_pct(75)
        assert await fields(link, "IRS:") == [700, 33]
        assert abs((await fields(link, "DOCK:"))[0] - 14_000) <= 40
        assert await fields(link, "BUMP:") == [0, 1]
        assert abs((await fields(link, "WALL:"))[0] - 20) <= 1
        assert abs((await fields(link, "BIN:"))[0] - 75) <= 1

    async def test_the_battery_dock_flag_follows_the_contact_voltage(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """BAT's dock flag is 1 from 5 V on the contacts, 0 below (the behaviour judges limits)."""
        await mcu.set_contact_mv(4_500)
        await link.telemetry_matching("DOCK:")
        assert (await fields(link, "BAT:"))[2] == 0
        await mcu.set_contact_mv(5_200)
        await link.telemetry_matching("DOCK:")
        assert (await fields(link, "BAT:"))[2] == 1

    async def test_mux_switching_leaves_the_eyes_alone(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """The shift register's mux bits change 80 times a second; the LED bits do not."""
        await link.command(1, "LED_IDLE")
        await mcu.set_dock_signal(500, 500)
        for _ in range(10):
            await link.telemetry_matching("IRS:")
        eyes = [pins.leds & 0x3 for pins in list(mcu.events)[-20:]]
        assert all(bits in (0x0, 0x3) for bits in eyes)  # IDLE: both on, or both off to blink


class TestEvac:
    async def test_evac_drives_its_output_and_a_reset_clears_it(
            self, mcu: SimavrMcu, link: PtyLink) -> None:
        """EVAC:1 sets the 595's EVAC output, EVAC:0 clears it; a bad value is refused."""
        assert (await mcu.state()).evac == 0
        assert await link.command(1, "EVAC:1") == "#1 ACK"
        await mcu.wait_for(lambda p: p.evac == 1)
        assert await link.command(2, "EVAC:3") == "#2 NAK:RANGE"
        assert (await mcu.state()).evac == 1
        assert await link.command(3, "EVAC:0") == "#3 ACK"
        await mcu.wait_for(lambda p: p.evac == 0)
        assert await link.command(4, "EVAC:1") == "#4 ACK"
        await mcu.wait_for(lambda p: p.evac == 1)
        mcu.reset()
        await mcu.wait_for(lambda p: p.evac == 0)
