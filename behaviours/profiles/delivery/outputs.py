"""Carries out the state tables' LEDs, box moves and sounds, one transition after another.

Each transition's ``Outputs`` are queued and done in order by one task, so a close always
follows its open and two sounds never overlap. LEDs and the box of every transition are done;
sounds of a transition that a newer one has already overtaken are skipped (the robot does not
ask for the QR code after the customer walked away) and a sound playing when a new transition
arrives is cut short.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import structlog

from behaviours.profiles.delivery.box import BoxController
from behaviours.profiles.delivery.states import Outputs
from hal.devices import Audio, Leds

log = structlog.get_logger(__name__)


class StateOutputs:
    """Args: the LEDs, the box and the speaker, each optional (a robot may lack one)."""

    def __init__(self, leds: Leds | None, box: BoxController | None, audio: Audio | None
                 ) -> None:
        self.leds = leds
        self.box = box
        self.audio = audio
        self._queue: asyncio.Queue[Outputs] = asyncio.Queue()
        self.skipped_sounds = 0

    def post(self, outputs: Outputs) -> None:
        """Queue a transition's outputs (called from a state hook: returns at once)."""
        self._queue.put_nowait(outputs)
        if self.audio is not None and outputs.sounds:
            # Cut what is playing now: it belongs to a state that was left.
            asyncio.get_running_loop().create_task(self.audio.stop())

    async def run(self) -> None:
        while True:
            outputs = await self._queue.get()
            await self.apply(outputs, overtaken=lambda: not self._queue.empty())

    async def apply(self, outputs: Outputs, overtaken: Callable[[], bool] | None = None
                    ) -> None:
        """Do ``outputs`` now; sounds are skipped once ``overtaken()`` says a newer one waits."""
        for mode in outputs.leds:
            if self.leds is not None:
                try:
                    await self.leds.show(mode)
                except Exception as exc:  # LEDs are cosmetic; never stop a delivery for them
                    log.warning("delivery.led_failed", mode=mode.value, error=str(exc))
        for angle_deg in outputs.box_deg:
            if self.box is not None:
                await self.box.move(angle_deg)
        for sound in outputs.sounds:
            if overtaken is not None and overtaken():
                self.skipped_sounds += 1
                continue
            if self.audio is not None:
                await self.audio.play(sound)
