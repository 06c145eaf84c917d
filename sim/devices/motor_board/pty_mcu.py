"""A FakeMcu on a real pseudo-terminal, for technicians, probes and the conformance suite.

``PtyMcu`` opens a pty, serves the FakeMcu on its master side and gives the slave's path, which
the real driver opens like ``/dev/ttyACM0`` (pyserial and all). With ``link`` it keeps a stable
symlink to the current slave, like ``/dev/serial/by-id``: ``unplug()`` closes the pty (the
host's reads fail, opening fails) and ``replug()`` makes a new one behind the same link.

``python -m sim.devices.motor_board.pty_mcu [--link PATH] [--corrupt PCT] [--seed N]``
prints the path, serves until killed, and prints what the MCU executed as JSON when it stops.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import json
import os
import signal
import sys
import tty
from pathlib import Path
from typing import Any

from hal.ports import StreamPair
from sim.devices.motor_board.fake_mcu import FakeMcu
from sim.world.plant import RecordingPlant


class PtyMcu:
    """Serves ``mcu`` on a pseudo-terminal; ``path`` is what a driver opens."""

    def __init__(self, mcu: FakeMcu, *, link: str | Path | None = None) -> None:
        self.mcu = mcu
        self.link = Path(link) if link is not None else None
        self.slave_path = ""
        self._master = -1
        self._slave = -1
        self._transports: list[asyncio.BaseTransport] = []
        mcu.plug_listeners.append(self._on_plug)

    @property
    def path(self) -> str:
        return str(self.link) if self.link is not None else self.slave_path

    async def start(self) -> str:
        await self._open()
        return self.path

    async def close(self) -> None:
        self.mcu.plug_listeners.remove(self._on_plug)
        self._hangup()
        await self.mcu.close()

    async def _open(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: bytes pass as on a UART
        self._master, self._slave = master, slave
        self.slave_path = os.ttyname(slave)
        if self.link is not None:
            link_to(self.link, self.slave_path)
        self.mcu.connect(await self._streams(master), hangup=self._hangup)

    async def _streams(self, master: int) -> StreamPair:
        streams, self._transports = await pty_streams(master)
        return streams

    def _hangup(self) -> None:
        """Close the pty: the slave path disappears and the host's port fails."""
        for transport in self._transports:
            transport.close()
        self._transports = []
        for fd in (self._master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = -1
        if self.link is not None:
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()

    def _on_plug(self, plugged: bool) -> None:
        if plugged:
            asyncio.get_running_loop().create_task(self._open())


def link_to(link: Path, target: str) -> None:
    """Point ``link`` at ``target`` atomically (a stable name, as /dev/serial/by-id's)."""
    tmp = link.with_name(link.name + ".tmp")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    tmp.replace(link)


async def pty_streams(master: int) -> tuple[StreamPair, list[asyncio.BaseTransport]]:
    """Reader and writer on a pty's master side (the device's end of the cable), and the
    transports that closing the line closes."""
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(loop=loop)
    protocol = asyncio.StreamReaderProtocol(reader, loop=loop)
    read_file = os.fdopen(os.dup(master), "rb", buffering=0)
    write_file = os.fdopen(os.dup(master), "wb", buffering=0)
    # The write side needs its own protocol (for drain); a reader takes one transport only.
    write_protocol = asyncio.StreamReaderProtocol(asyncio.StreamReader(loop=loop), loop=loop)
    read_transport, _ = await loop.connect_read_pipe(lambda: protocol, read_file)
    write_transport, _ = await loop.connect_write_pipe(lambda: write_protocol, write_file)
    writer = asyncio.StreamWriter(write_transport, write_protocol, reader, loop)
    return (reader, writer), [read_transport, write_transport]


def summary(mcu: FakeMcu) -> dict[str, Any]:
    """What the MCU saw, for a test or a technician: counts, duplicates, order."""
    seqs = [e.seq for e in mcu.executed if e.seq is not None]
    out_of_order = sum(1 for a, b in itertools.pairwise(seqs) if b != (a + 1) % 256)
    return {
        "executed": len(mcu.executed), "duplicates_suppressed": mcu.duplicates,
        "naks": len(mcu.naks), "dropped_frames": mcu.dropped_frames,
        "seq_gaps": out_of_order, "deadman_stops": len(mcu.deadman_stops),
        "payloads": [e.payload for e in mcu.executed][-5:],
    }


async def _serve(args: argparse.Namespace) -> None:
    mcu = FakeMcu(RecordingPlant(), seed=args.seed, firmware=args.firmware,
                  reset_on_open=args.boot_s > 0, boot_s=args.boot_s)
    mcu.corrupt(args.corrupt)
    mcu.delay(args.delay)
    server = PtyMcu(mcu, link=args.link)
    print(await server.start(), flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()
    await server.close()
    print(json.dumps(summary(mcu)), flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim.devices.motor_board.pty_mcu",
                                     description="Serve a fake motor board on a pty.")
    parser.add_argument("--link", help="keep a symlink to the pty here")
    parser.add_argument("--corrupt", type=float, default=0.0, help="%% of bytes to corrupt")
    parser.add_argument("--delay", type=float, default=0.0, help="reply delay in seconds")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--firmware", default="fake-mcu-1.0")
    parser.add_argument("--boot-s", type=float, default=0.0,
                        help="boot (deaf) this long at start and on replug, like an Uno")
    asyncio.run(_serve(parser.parse_args(argv)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
