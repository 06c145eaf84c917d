"""The link's line receiver: bytes from the port to parsed lines, on the transport or pumped."""

from __future__ import annotations

import asyncio
import itertools

from hypothesis import given
from hypothesis import strategies as st
from serial_frames import frame_body

from drivers.arduino.framing import Ack, Framing, Garbled, Line, Telemetry
from drivers.arduino.receiver import LineReceiver, LinkBroken
from drivers.arduino.stats import LinkCounters
from sim import vclock
from sim.devices.byte_pipe import BytePipe


class Catch:
    """A receiver with what it handed on."""

    def __init__(self) -> None:
        self.lines: list[Line] = []
        self.ended: list[BaseException] = []
        self.counters = LinkCounters()
        self.receiver = LineReceiver(Framing.CRC, self.counters, self.lines.append,
                                     self.ended.append)


class TestOnTheTransport:
    def test_lines_split_across_and_within_writes_arrive_in_order(self) -> None:
        """Whatever the chunking, each whole line is handed on once, parsed, in order."""

        async def main() -> None:
            pipe = BytePipe()
            catch = Catch()
            assert catch.receiver.attach(pipe.a)
            ack, enc = frame_body(b"#3 ACK"), frame_body(b"ENCODER:5,-6")
            device = pipe.b[1]
            device.write(ack + enc[:4])
            device.write(enc[4:])
            device.write(ack)
            await asyncio.sleep(0.01)
            assert catch.lines == [Ack(3), Telemetry("ENCODER", ("5", "-6")), Ack(3)]
            pipe.close()

        vclock.run(main())

    def test_an_overlong_line_is_counted_and_dropped_up_to_its_end(self) -> None:
        """Past 64 bytes a line is noise: counted once, nothing of it handed on."""

        async def main() -> None:
            pipe = BytePipe()
            catch = Catch()
            assert catch.receiver.attach(pipe.a)
            pipe.b[1].write(b"X" * 70)
            pipe.b[1].write(b"Y" * 10 + b"\n" + frame_body(b"#1 ACK"))
            await asyncio.sleep(0.01)
            assert catch.lines == [Ack(1)]
            assert catch.counters.overlong == 1
            pipe.close()

        vclock.run(main())

    def test_a_damaged_line_is_handed_on_as_garbled(self) -> None:
        """The receiver parses; deciding what a garbled line means is the session's job."""

        async def main() -> None:
            pipe = BytePipe()
            catch = Catch()
            assert catch.receiver.attach(pipe.a)
            pipe.b[1].write(b"#1 ACK*00\n")
            await asyncio.sleep(0.01)
            assert isinstance(catch.lines[0], Garbled)
            pipe.close()

        vclock.run(main())

    def test_the_end_of_the_line_reaches_the_receiver_and_the_writer(self) -> None:
        """A vanished port is reported once, and the writer still sees its connection end."""

        async def main() -> None:
            pipe = BytePipe()
            catch = Catch()
            reader, writer = pipe.a
            assert catch.receiver.attach(pipe.a)
            pipe.break_()
            assert len(catch.ended) == 1 and isinstance(catch.ended[0], OSError)
            assert reader.exception() is catch.ended[0]
            writer.close()

        vclock.run(main())

    def test_a_failing_line_handler_ends_the_connection_and_later_bytes_are_ignored(
            self) -> None:
        """What the handler raises is reported as the end; nothing is handed on after it."""

        async def main() -> None:
            pipe = BytePipe()
            ended: list[BaseException] = []
            seen: list[Line] = []

            def on_line(line: Line) -> None:
                seen.append(line)
                raise RuntimeError("boom")

            receiver = LineReceiver(Framing.CRC, LinkCounters(), on_line, ended.append)
            assert receiver.attach(pipe.a)
            pipe.b[1].write(frame_body(b"#1 ACK") + frame_body(b"#2 ACK"))
            await asyncio.sleep(0.01)
            assert len(seen) == 1
            assert isinstance(ended[0], RuntimeError)
            pipe.close()

        vclock.run(main())


class TestPumped:
    def test_a_reader_with_bytes_already_buffered_is_pumped_with_the_same_result(
            self) -> None:
        """Bytes a reader holds are not lost: attach refuses and pump() reads them, then
        the rest, and reports end of file as LinkBroken."""

        async def main() -> None:
            pipe = BytePipe()
            catch = Catch()
            pipe.b[1].write(frame_body(b"#1 ACK"))
            await asyncio.sleep(0.01)
            assert not catch.receiver.attach(pipe.a)
            pump = asyncio.create_task(catch.receiver.pump(pipe.a[0]))
            pipe.b[1].write(frame_body(b"#2 ACK"))
            await asyncio.sleep(0.01)
            pipe.close()
            await pump
            assert catch.lines == [Ack(1), Ack(2)]
            assert len(catch.ended) == 1 and isinstance(catch.ended[0], LinkBroken)

        vclock.run(main())


_LINES = st.sampled_from([frame_body(b"#3 ACK"), frame_body(b"ENCODER:5,-6"), frame_body(b"IR:7"),
                          b"X" * 70 + b"\n", b"#1 ACK*00\n", b"\n", b"\r\n", b"IR:5",
                          b"Y" * 63 + b"\n", b"Z" * 64 + b"\n"])


class TestChunking:
    @given(st.lists(_LINES, max_size=12), st.lists(st.integers(0, 200), max_size=8))
    def test_any_chunking_hands_on_what_byte_by_byte_does(self, lines: list[bytes],
                                                          cuts: list[int]) -> None:
        """Whole lines in one chunk, several, or parts of them: the lines handed on and the
        overlong count are those of the same bytes arriving one at a time."""
        stream = b"".join(lines)
        by_byte, chunked = Catch(), Catch()
        for i in range(len(stream)):
            by_byte.receiver.data_received(stream[i:i + 1])
        bounds = sorted({0, len(stream), *(cut for cut in cuts if cut < len(stream))})
        for start, end in itertools.pairwise(bounds):
            chunked.receiver.data_received(stream[start:end])
        assert chunked.lines == by_byte.lines
        assert chunked.counters.overlong == by_byte.counters.overlong
