"""The incremental LD19 parser: any chunking, faults counted, intact packets all out."""

from __future__ import annotations

import itertools
import random

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lidar_stream import HEADER_IN_DISTANCE_MM, faulty_stream, turn_packets

from drivers.lidar.packet import Packet, from_records
from drivers.lidar.parser import PacketParser


def parse_in_chunks(data: bytes, cuts: list[int], parser: PacketParser | None = None
                    ) -> tuple[list[Packet], PacketParser]:
    parser = parser or PacketParser()
    out: list[Packet] = []
    edges = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    for a, b in itertools.pairwise(edges):
        out += from_records(parser.feed(data[a:b]))
    return out, parser


@st.composite
def plausible_packets(draw: st.DrawFn) -> Packet:
    """Any packet the parser must accept: a speed of 1-20 Hz, a span that fits it."""
    speed = draw(st.integers(360, 7200))
    factor = draw(st.floats(0.55, 1.45))
    start = draw(st.integers(0, 35999))
    span = round(speed * 11 / 4500 * 100 * factor)
    return Packet(speed_dps=speed, start_cdeg=start, end_cdeg=(start + span) % 36000,
                  timestamp_ms=draw(st.integers(0, 29999)),
                  distances_mm=tuple(draw(st.lists(st.integers(0, 65535), min_size=12,
                                                   max_size=12))),
                  intensities=tuple(draw(st.lists(st.integers(0, 255), min_size=12,
                                                  max_size=12))))


class TestRoundTrip:
    @given(st.lists(plausible_packets(), min_size=1, max_size=20),
           st.lists(st.integers(0, 10_000), max_size=30))
    def test_encode_split_anywhere_parse_gives_the_packets_back(
            self, packets: list[Packet], cuts: list[int]) -> None:
        """LD19 encode -> split at random -> parse returns every packet, field for field."""
        data = b"".join(p.encode() for p in packets)
        out, parser = parse_in_chunks(data, cuts)
        assert out == packets
        c = parser.counters
        assert (c.crc_errors, c.implausible, c.skipped_bytes, c.bytes) == (0, 0, 0, len(data))


class TestFaultyStream:
    @settings(derandomize=True, max_examples=60,
              suppress_health_check=[HealthCheck.too_slow])
    @given(st.integers(0, 2**32 - 1), st.lists(st.integers(0, 100_000), max_size=60))
    def test_every_intact_packet_comes_out_and_every_damaged_one_is_counted(
            self, seed: int, cuts: list[int]) -> None:
        """CRC errors, truncations, stray 54/2C bytes, 54 2C in distances, a timestamp wrap,
        fed in random chunks: the intact packets come out in order, each damaged one adds to
        crc_errors/implausible, nothing raises."""
        stream = faulty_stream(120, seed)
        out, parser = parse_in_chunks(stream.data, cuts)
        assert out == stream.intact
        c = parser.counters
        assert c.crc_errors + c.implausible >= stream.damaged
        assert c.packets == len(stream.intact) and c.bytes == len(stream.data)
        if stream.damaged:
            assert c.resyncs >= 1 and c.skipped_bytes > 0

    def test_the_stream_really_has_its_hard_cases(self) -> None:
        """The generated stream holds 54 2C distances, a timestamp wrap and damage."""
        stream = faulty_stream(120, 7)
        assert stream.header_in_distance > 0 and stream.damaged > 10
        stamps = [p.timestamp_ms for p in stream.intact]
        assert any(b < a for a, b in itertools.pairwise(stamps))

    @given(st.binary(max_size=3000), st.lists(st.integers(0, 3000), max_size=20))
    def test_arbitrary_bytes_never_raise_and_every_byte_is_accounted(
            self, data: bytes, cuts: list[int]) -> None:
        """Noise in any chunking: no exception; bytes fed are counted."""
        _, parser = parse_in_chunks(data, cuts)
        assert parser.counters.bytes == len(data)

    def test_a_truncated_packet_costs_only_itself(self) -> None:
        """A packet cut after 20 bytes, then an intact one: the intact one comes out (the
        SDK's skip-47 would lose it)."""
        first, second, third = (Packet(3600, a, a + 880, a // 36, (1500,) * 12, (99,) * 12)
                                for a in (0, 960, 1920))
        data = first.encode() + second.encode()[:20] + third.encode()
        out, parser = parse_in_chunks(data, [])
        assert out == [first, third]
        assert parser.counters.crc_errors == 1
        assert parser.counters.skipped_bytes == 20 and parser.counters.resyncs == 1

    def test_header_bytes_inside_a_distance_are_not_a_packet(self) -> None:
        """A distance of 11348 mm (54 2C) inside an accepted packet is never a header."""
        packet = Packet(3600, 0, 880, 5, (HEADER_IN_DISTANCE_MM,) * 12, (0x54,) * 12)
        data = packet.encode() * 3
        out, parser = parse_in_chunks(data, [50, 51, 99])
        assert out == [packet] * 3
        assert parser.counters.crc_errors == 0 and parser.counters.resyncs == 0

    def test_a_crc_valid_packet_with_an_impossible_span_is_refused(self) -> None:
        """Good CRC, but its points would span 90 degrees at 10 Hz: counted implausible."""
        bad = Packet(3600, 0, 9000, 0, (1000,) * 12, (100,) * 12)
        good = turn_packets(1)[0]
        out, parser = parse_in_chunks(bad.encode() + good.encode(), [])
        assert out == [good] and parser.counters.implausible == 1

    def test_byte_by_byte_equals_all_at_once(self) -> None:
        """Feeding one byte at a time gives what one feed gives, counters included."""
        stream = faulty_stream(40, 3)
        whole, p1 = parse_in_chunks(stream.data, [])
        single, p2 = parse_in_chunks(stream.data, list(range(len(stream.data))))
        assert whole == single == stream.intact
        assert p1.counters == p2.counters
        rng = random.Random(1)
        cuts = [rng.randrange(len(stream.data)) for _ in range(30)]
        assert parse_in_chunks(stream.data, cuts)[1].counters == p1.counters
