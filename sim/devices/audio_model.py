"""Simulated audio: records what was played and lasts each file's duration in virtual time.

The duration comes from the WAV header (``wave``), so a mission's timing with sounds is the
robot's. A missing or unreadable file is a warning and a recorded failure, as on the robot.
``write_tone_wav`` makes stand-in files of a given length for scenarios and tests (the seed's
recordings are not in the repository).
"""

from __future__ import annotations

import asyncio
import math
import struct
import wave
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import structlog

log = structlog.get_logger(__name__)


@dataclass(frozen=True, slots=True)
class Played:
    """One sound as the simulated speaker played it: when, what, and whether it was cut."""

    t_s: float
    sound: str
    duration_s: float
    cut: bool = False


class SimAudio:
    """A `hal.devices.Audio` over a directory of WAV files, on the event loop's clock."""

    def __init__(self, audio_dir: Path, *, name: str = "audio") -> None:
        self.name = name
        self.audio_dir = audio_dir
        self.played: list[Played] = []
        self.failures: list[tuple[float, str, str]] = []
        self._durations: dict[str, float] = {}
        self._playing: asyncio.Future[None] | None = None

    async def start(self) -> None:
        return None

    async def close(self) -> None:
        await self.stop()

    def status(self) -> dict[str, Any]:
        return {"source": "sim", "played": len(self.played), "failures": len(self.failures),
                "playing": self._playing is not None}

    def sounds(self) -> list[str]:
        """The names played so far, in order (for success checks)."""
        return [p.sound for p in self.played]

    async def play(self, sound: str) -> None:
        loop = asyncio.get_running_loop()
        duration_s = self._duration(sound)
        if duration_s is None:
            return
        await self.stop()
        done: asyncio.Future[None] = loop.create_future()
        self._playing = done
        t0 = loop.time()
        log.info("audio.play", sound=sound, duration_s=round(duration_s, 3))
        try:
            await asyncio.wait_for(asyncio.shield(done), duration_s)
            cut = True
        except TimeoutError:
            cut = False
        except asyncio.CancelledError:
            self.played.append(Played(t0, sound, loop.time() - t0, cut=True))
            raise
        finally:
            if self._playing is done:
                self._playing = None
        self.played.append(Played(t0, sound, loop.time() - t0, cut=cut))

    async def stop(self) -> None:
        playing, self._playing = self._playing, None
        if playing is not None and not playing.done():
            playing.set_result(None)

    def _duration(self, sound: str) -> float | None:
        if sound in self._durations:
            return self._durations[sound]
        name = sound if sound.endswith(".wav") else f"{sound}.wav"
        path = self.audio_dir / name
        if "/" in name or ".." in name:
            self._fail(sound, f"sound name {sound!r} is not a plain file name")
            return None
        try:
            with wave.open(str(path), "rb") as wav:
                duration_s = wav.getnframes() / wav.getframerate()
        except FileNotFoundError:
            self._fail(sound, f"no sound file {path}")
            return None
        except (OSError, EOFError, ZeroDivisionError, wave.Error) as exc:
            self._fail(sound, f"{path}: not a readable WAV file ({exc})")
            return None
        self._durations[sound] = duration_s
        return duration_s

    def _fail(self, sound: str, message: str) -> None:
        t_s = asyncio.get_running_loop().time()
        self.failures.append((t_s, sound, message))
        log.warning("audio.file_missing", sound=sound, message=message)


def write_tone_wav(path: Path, duration_s: float, *, frequency_hz: float = 660.0,
                   rate_hz: int = 8000) -> None:
    """A mono 16-bit WAV of a quiet tone lasting ``duration_s`` (a stand-in recording)."""
    frames = round(duration_s * rate_hz)
    samples = (int(3000 * math.sin(2 * math.pi * frequency_hz * i / rate_hz))
               for i in range(frames))
    with wave.open(str(path), "wb") as wav:
        wav.setnchannels(1)
        wav.setsampwidth(2)
        wav.setframerate(rate_hz)
        wav.writeframes(b"".join(struct.pack("<h", s) for s in samples))
