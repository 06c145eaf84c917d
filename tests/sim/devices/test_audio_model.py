"""Simulated audio: records what was played, for as long as the WAV file lasts (virtual time)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from hal.devices import Audio
from sim import vclock
from sim.devices.audio_model import SimAudio, write_tone_wav


def audio_with(tmp_path: Path, **durations_s: float) -> SimAudio:
    for name, duration_s in durations_s.items():
        write_tone_wav(tmp_path / f"{name}.wav", duration_s)
    return SimAudio(tmp_path)


def test_play_lasts_the_files_duration(tmp_path: Path) -> None:
    """A 2.5 s file takes 2.5 s of loop time and is recorded with its start."""
    audio = audio_with(tmp_path, request_qr=2.5, order_accepted=1.25)
    assert isinstance(audio, Audio)

    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await audio.play("request_qr")
        await audio.play("order_accepted")
        return loop.time() - t0

    assert vclock.run(main()) == pytest.approx(3.75)
    assert audio.sounds() == ["request_qr", "order_accepted"]
    assert audio.played[1].t_s - audio.played[0].t_s == pytest.approx(2.5)


def test_stop_cuts_the_sound(tmp_path: Path) -> None:
    """stop() ends play() at once; the sound is recorded as cut."""
    audio = audio_with(tmp_path, delivery_greeting=4.0)

    async def main() -> None:
        task = asyncio.create_task(audio.play("delivery_greeting"))
        await asyncio.sleep(1.0)
        await audio.stop()
        await task

    vclock.run(main())
    assert audio.played[0].cut and audio.played[0].duration_s == pytest.approx(1.0)


def test_a_missing_file_is_recorded_not_raised(tmp_path: Path) -> None:
    """No file: play returns at once and the failure is kept."""
    audio = SimAudio(tmp_path)
    vclock.run(audio.play("order_rejected"))
    assert audio.played == [] and audio.failures[0][1] == "order_rejected"


def test_a_file_that_is_not_wav_is_recorded_not_raised(tmp_path: Path) -> None:
    """A broken file is a failure naming the file."""
    (tmp_path / "x.wav").write_bytes(b"not a wav")
    audio = SimAudio(tmp_path)
    vclock.run(audio.play("x"))
    assert "not a readable WAV" in audio.failures[0][2]
