"""``robotd probe serial`` against boards that never shake hands says what it got, on a pty."""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import tty
from collections.abc import AsyncIterator
from pathlib import Path

ROBOTD = Path(sys.executable).with_name("robotd")
GARBAGE = b"\x00\xff\xfeNOISE 9600 baud?\r\n\x1b[2J"


async def probe(config: Path, port: str) -> tuple[int, str]:
    command = [str(ROBOTD), "probe", "serial"] if ROBOTD.exists() else [
        sys.executable, "-m", "robotd.probes.serial"]
    proc = await asyncio.create_subprocess_exec(
        *command, "--config", str(config), "--port", port, "--count", "1",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    _, err = await asyncio.wait_for(proc.communicate(), 60)
    return proc.returncode or 0, err.decode()


@contextlib.asynccontextmanager
async def board(answer: bytes) -> AsyncIterator[str]:
    """A pty whose far end answers every chunk it reads with ``answer`` (b"": stays silent)."""
    master, slave = os.openpty()
    tty.setraw(slave)
    loop = asyncio.get_running_loop()

    def on_readable() -> None:
        try:
            os.read(master, 4096)
        except OSError:
            return
        if answer:
            os.write(master, answer)

    loop.add_reader(master, on_readable)
    try:
        yield os.ttyname(slave)
    finally:
        loop.remove_reader(master)
        os.close(master)
        os.close(slave)


def short_handshake(tmp_path: Path) -> Path:
    config = tmp_path / "robotd.toml"
    config.write_text("[serial]\nhandshake_timeout_s = 0.5\n")
    return config


class TestHandshakeFailure:
    async def test_a_board_that_answers_garbage_is_shown_counted_and_excerpted(
            self, tmp_path: Path) -> None:
        """Exit 1; the message counts the bytes and shows them printably, not ``failed: ``."""
        async with board(GARBAGE) as port:
            code, err = await probe(short_handshake(tmp_path), port)
        assert code == 1
        line = err.strip().splitlines()[-1]
        assert line.startswith("probe serial: probe on ") and "handshake failed" in line
        assert "but no HELLO reply" in line and not line.endswith(":")
        assert "received " in line and "\\x00\\xff\\xfeNOISE 9600 baud?\\r\\n\\x1b[2J" in line

    async def test_a_silent_board_is_said_to_have_sent_nothing(self, tmp_path: Path) -> None:
        async with board(b"") as port:
            code, err = await probe(short_handshake(tmp_path), port)
        assert code == 1
        assert "nothing came from the board" in err.strip().splitlines()[-1]
