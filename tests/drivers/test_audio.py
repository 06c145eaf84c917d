"""The aplay audio driver, against stand-in players (real subprocesses, no patching)."""

from __future__ import annotations

import asyncio
import stat
from pathlib import Path

from drivers.audio import AplayAudio, sound_file
from hal.devices import Audio


def fake_player(tmp_path: Path, body: str) -> str:
    """An executable that stands in for aplay: it logs its arguments, then runs ``body``."""
    script = tmp_path / "fake-aplay"
    script.write_text(f'#!/bin/sh\necho "$@" >> "{tmp_path}/calls"\n{body}\n')
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    return str(script)


def sounds_dir(tmp_path: Path, *names: str) -> Path:
    directory = tmp_path / "audio"
    directory.mkdir()
    for name in names:
        (directory / f"{name}.wav").write_bytes(b"RIFF")
    return directory


async def test_plays_a_file_with_the_player(tmp_path: Path) -> None:
    """play runs the player on <dir>/<name>.wav and returns when it ends."""
    audio = AplayAudio(sounds_dir(tmp_path, "request_qr"), player=fake_player(tmp_path, "exit 0"),
                       device="hw:1")
    assert isinstance(audio, Audio)
    await audio.start()
    await audio.play("request_qr")
    assert audio.played == ["request_qr"]
    assert (tmp_path / "calls").read_text().split() == [
        "-q", "-D", "hw:1", str(tmp_path / "audio" / "request_qr.wav")]


async def test_a_missing_file_is_a_warning_not_a_crash(tmp_path: Path) -> None:
    """No such sound: nothing runs, the failure is counted and named."""
    audio = AplayAudio(sounds_dir(tmp_path), player=fake_player(tmp_path, "exit 0"))
    await audio.play("order_accepted")
    assert audio.failures == {"file_missing": 1}
    assert "order_accepted.wav" in str(audio.last_error)
    assert not (tmp_path / "calls").exists()


async def test_a_missing_player_is_a_warning_not_a_crash(tmp_path: Path) -> None:
    """No aplay installed: start and play warn; nothing raises."""
    audio = AplayAudio(sounds_dir(tmp_path, "x"), player=str(tmp_path / "no-such-aplay"))
    await audio.start()
    await audio.play("x")
    assert audio.failures == {"player_missing": 2}


async def test_a_failing_player_is_reported(tmp_path: Path) -> None:
    """aplay exiting non-zero (no sound card): its last message is kept."""
    player = fake_player(tmp_path, 'echo "aplay: main:831: audio open error" >&2; exit 1')
    audio = AplayAudio(sounds_dir(tmp_path, "x"), player=player)
    await audio.play("x")
    assert audio.failures == {"player_failed": 1}
    assert "audio open error" in str(audio.last_error)


async def test_stop_and_cancel_end_the_process(tmp_path: Path) -> None:
    """stop() kills a playing sound; a cancelled play() kills it too; neither waits 30 s."""
    audio = AplayAudio(sounds_dir(tmp_path, "long"), player=fake_player(tmp_path, "exec sleep 30"))
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    task = asyncio.create_task(audio.play("long"))
    await asyncio.sleep(0.2)
    await audio.stop()
    await task
    task = asyncio.create_task(audio.play("long"))
    await asyncio.sleep(0.2)
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    assert loop.time() - t0 < 5
    assert audio.played == []
    assert audio.status()["playing"] is False


def test_sound_names_stay_inside_the_directory() -> None:
    """Path tricks are refused; plain names gain .wav."""
    base = Path("/snd")
    assert sound_file(base, "announce_order_12") == Path("/snd/announce_order_12.wav")
    assert sound_file(base, "successScan.wav") == Path("/snd/successScan.wav")
    for bad in ("../etc/passwd", "a/b", "", ".hidden", "x" * 100):
        assert sound_file(base, bad) is None
