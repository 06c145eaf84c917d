"""The real serial port: a ``SerialOpener`` on pyserial-asyncio-fast (8N1, no flow control)."""

from __future__ import annotations

import serial
import serial_asyncio_fast

from hal.ports import StreamPair


async def open_serial(port: str, baud: int) -> StreamPair:
    """Open ``port`` at ``baud`` 8N1; OSError (with the port in the message) when absent."""
    try:
        return await serial_asyncio_fast.open_serial_connection(
            url=port, baudrate=baud, bytesize=8, parity="N", stopbits=1,
            rtscts=False, xonxoff=False, dsrdtr=False, exclusive=True,
        )
    except serial.SerialException as exc:
        # pyserial's SerialException is an OSError without errno; its text names the port.
        raise OSError(str(exc)) from exc
