"""The coalescing transport under uvicorn's protocol (fleet.http_protocol): what is written in
one loop turn goes out in one send, in order, and nothing is lost on close."""

from __future__ import annotations

import asyncio

from fleet.http_protocol import CoalescingTransport


class RecordingTransport(asyncio.Transport):
    """Stands for the socket's transport: records each write and the close."""

    def __init__(self) -> None:
        super().__init__()
        self.writes: list[bytes] = []
        self.closed = False
        self.aborted = False

    def write(self, data: bytes | bytearray | memoryview) -> None:
        self.writes.append(bytes(data))

    def close(self) -> None:
        self.closed = True

    def abort(self) -> None:
        self.aborted = True

    def is_closing(self) -> bool:
        return self.closed or self.aborted

    def get_extra_info(self, name: str, default: object = None) -> object:
        return ("127.0.0.1", 8080) if name == "sockname" else default

    def get_write_buffer_size(self) -> int:
        return 0


async def next_turn() -> None:
    await asyncio.sleep(0)


class TestCoalescingTransport:
    async def test_writes_of_one_turn_go_out_in_one_send_in_order(self):
        """A response's head and body, written back to back, are one write."""
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        transport.write(b"HTTP/1.1 200 OK\r\ncontent-length: 2\r\n\r\n")
        transport.write(b"{}")
        assert socket.writes == []
        assert transport.get_write_buffer_size() == 40
        await next_turn()
        assert socket.writes == [b"HTTP/1.1 200 OK\r\ncontent-length: 2\r\n\r\n{}"]

    async def test_writes_of_later_turns_are_sent_separately(self):
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        transport.write(b"a")
        await next_turn()
        transport.write(b"b")
        await next_turn()
        assert socket.writes == [b"a", b"b"]

    async def test_close_sends_what_is_pending_first(self):
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        transport.write(b"HTTP/1.1 400 Bad Request\r\n\r\n")
        transport.close()
        assert socket.writes == [b"HTTP/1.1 400 Bad Request\r\n\r\n"]
        assert socket.closed
        await next_turn()
        assert len(socket.writes) == 1

    async def test_abort_drops_what_is_pending(self):
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        transport.write(b"lost")
        transport.abort()
        await next_turn()
        assert socket.writes == []
        assert socket.aborted

    async def test_nothing_is_written_to_a_closing_socket(self):
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        transport.write(b"late")
        socket.close()  # the peer went away
        await next_turn()
        assert socket.writes == []

    async def test_everything_else_is_the_sockets(self):
        socket = RecordingTransport()
        transport = CoalescingTransport(socket, asyncio.get_running_loop())
        assert transport.get_extra_info("sockname") == ("127.0.0.1", 8080)
        assert not transport.is_closing()
