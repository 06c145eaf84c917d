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
        self._queue: asyncio.Queue[tuple[int, Outputs]] = asyncio.Queue()
        self.skipped_sounds = 0
        self._posted = 0
        """How many transitions' outputs were posted (each one's number: its generation)."""
        self._playing: int | None = None
        """The generation whose sound is playing now (None: silence)."""

    def post(self, outputs: Outputs) -> None:
        """Queue a transition's outputs (called from a state hook: returns at once)."""
        self._posted += 1
        self._queue.put_nowait((self._posted, outputs))
        if self.audio is not None and outputs.sounds and self._playing is not None:
            # Cut what is playing now: it belongs to a state that was left.
            asyncio.get_running_loop().create_task(self._cut(self._playing))

    async def _cut(self, generation: int) -> None:
        # Only the sound of that older transition: by the time this runs it may have ended
        # and the new transition's own sound started, which must be heard whole.
        if self.audio is not None and self._playing == generation:
            await self.audio.stop()

    async def run(self) -> None:
        while True:
            generation, outputs = await self._queue.get()
            await self.apply(outputs, overtaken=lambda: not self._queue.empty(),
                             generation=generation)

    async def apply(self, outputs: Outputs, overtaken: Callable[[], bool] | None = None,
                    generation: int = 0) -> None:
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
                self._playing = generation
                try:
                    await self.audio.play(sound)
                finally:
                    self._playing = None
