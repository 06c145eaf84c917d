"""The simulator's ``SerialOpener``: port names lead to simulated devices over byte pipes."""

from __future__ import annotations

import errno
from typing import Protocol

from hal.ports import StreamPair
from sim.devices.byte_pipe import BytePipe


class SimSerialDevice(Protocol):
    """A device on a simulated port (the FakeMcu, the SimLd19): plugged in, and served."""

    plugged: bool

    def connect_pipe(self, pipe: BytePipe) -> None: ...


class SimSerialPorts:
    """Opens ``port`` as a byte pipe to the device attached there (a ``SerialOpener``).

    Opening a port with no device, or whose device is unplugged, raises FileNotFoundError, as
    a missing ``/dev/ttyACM0`` does. ``unplug()`` on the device breaks the open pipe.

    Args:
        wire_baud: model the wire's byte time at the baud the driver asks for (default True).
        seed: seed of the pipes' own fault generators.
    """

    def __init__(self, *, wire_baud: bool = True, seed: int = 0) -> None:
        self._mcus: dict[str, SimSerialDevice] = {}
        self._wire_baud = wire_baud
        self._seed = seed
        self.opens = 0
        self.pipe: BytePipe | None = None

    def attach(self, port: str, mcu: SimSerialDevice) -> None:
        self._mcus[port] = mcu

    async def __call__(self, port: str, baud: int) -> StreamPair:
        mcu = self._mcus.get(port)
        if mcu is None or not mcu.plugged:
            raise FileNotFoundError(errno.ENOENT, "No such file or directory", port)
        self.opens += 1
        pipe = BytePipe(baud=baud if self._wire_baud else None, seed=self._seed + self.opens)
        self.pipe = pipe
        mcu.connect_pipe(pipe)
        return pipe.a
