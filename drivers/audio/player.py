"""Sound files played by ``aplay`` (alsa-utils) in a subprocess.

Why a subprocess and not a Python audio library: the Pi needs no Python audio stack (no
PortAudio/SDL build, no pulseaudio) and ``aplay`` ships with every Raspberry Pi OS image; a
playing sound is cancelled by killing the process, which no blocking library call allows; and a
wedged sound card stalls a child process, never the event loop. A missing file, a missing player
or a failing card is a warning and an event (``audio.*``), never an exception.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import shutil
from pathlib import Path
from typing import Any

import structlog

log = structlog.get_logger(__name__)

_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}")
_KILL_WAIT_S = 1.0  # aplay exits at once on SIGTERM; SIGKILL after this


def sound_file(audio_dir: Path, sound: str) -> Path | None:
    """``audio_dir/<sound>.wav``, or None for a name that is not a plain file name."""
    name = sound if sound.endswith(".wav") else f"{sound}.wav"
    if not _NAME.fullmatch(name) or ".." in name:
        return None
    return audio_dir / name


class AplayAudio:
    """A `hal.devices.Audio` that plays ``<dir>/<sound>.wav`` with aplay; one sound at a time.

    Args:
        audio_dir: where the sound files are.
        player: the player program (``aplay``); its absence is a warning, not an error.
        device: ALSA device (``aplay -D``), empty for the default.
    """

    def __init__(self, audio_dir: Path, *, player: str = "aplay", device: str = "",
                 name: str = "audio") -> None:
        self.name = name
        self.audio_dir = audio_dir
        self.player = player
        self.device = device
        self._proc: asyncio.subprocess.Process | None = None
        self.played: list[str] = []
        self.failures: dict[str, int] = {}
        self.last_error: str | None = None

    async def start(self) -> None:
        if shutil.which(self.player) is None:
            self._fail("player_missing", f"{self.player} not found (install alsa-utils)")
        elif not self.audio_dir.is_dir():
            self._fail("dir_missing", f"no sound directory {self.audio_dir} (check audio.dir)")

    async def close(self) -> None:
        await self.stop()

    def status(self) -> dict[str, Any]:
        return {"dir": str(self.audio_dir), "played": len(self.played),
                "failures": dict(self.failures), "last_error": self.last_error,
                "playing": self._proc is not None}

    async def play(self, sound: str) -> None:
        """Play ``sound`` to its end (cut off any sound playing); a cancelled play stops it."""
        path = sound_file(self.audio_dir, sound)
        if path is None:
            self._fail("bad_name", f"sound name {sound!r} is not a plain file name")
            return
        if not path.is_file():
            self._fail("file_missing", f"no sound file {path}", sound=sound)
            return
        await self.stop()
        args = [self.player, "-q", *(["-D", self.device] if self.device else []), str(path)]
        try:
            proc = await asyncio.create_subprocess_exec(
                *args, stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.DEVNULL,
                stderr=asyncio.subprocess.PIPE)
        except OSError as exc:
            self._fail("player_missing", f"cannot run {self.player}: {exc}", sound=sound)
            return
        self._proc = proc
        log.info("audio.play", sound=sound)
        try:
            _, stderr = await proc.communicate()
        except asyncio.CancelledError:
            await self._kill(proc)
            raise
        finally:
            if self._proc is proc:
                self._proc = None
        if proc.returncode == 0:
            self.played.append(sound)
        elif proc.returncode is not None and proc.returncode > 0:
            text = stderr.decode("utf-8", "replace").strip().splitlines()
            self._fail("player_failed", f"{self.player} exited {proc.returncode}: "
                       f"{text[-1] if text else 'no message'}", sound=sound)

    async def stop(self) -> None:
        """Cut the sound playing now, if any."""
        proc, self._proc = self._proc, None
        if proc is not None:
            await self._kill(proc)

    async def _kill(self, proc: asyncio.subprocess.Process) -> None:
        if proc.returncode is not None:
            return
        with contextlib.suppress(ProcessLookupError):
            proc.terminate()
        try:
            await asyncio.wait_for(proc.wait(), _KILL_WAIT_S)
        except TimeoutError:
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
            await proc.wait()

    def _fail(self, what: str, message: str, **fields: Any) -> None:
        self.failures[what] = self.failures.get(what, 0) + 1
        self.last_error = message
        log.warning(f"audio.{what}", message=message, **fields)
