"""The dock IR edge decoder on recorded-style edge streams: clean, jittered, damaged."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.dock_ir.edge_decoder import EdgeDecoder
from hal.ports import IrEdge
from sim.devices import ir_emitter as em

DOCK_CODES = [161, 164, 168, 172, 165, 169, 173, 162]


def decode(edges: list[IrEdge], decoder: EdgeDecoder | None = None) -> tuple[list[int],
                                                                           EdgeDecoder]:
    decoder = decoder or EdgeDecoder()
    out = []
    for edge in edges:
        code = decoder.feed(edge.level, edge.t_us)
        if code is not None:
            out.append(code)
    if edges:
        code = decoder.flush(edges[-1].t_us + 100_000)
        if code is not None:
            out.append(code)
    return out, decoder


def stream(codes: list[int], *, jitter_us: int = 0, seed: int = 1,
           active_low: bool = True) -> list[IrEdge]:
    marks, _ = em.stream_marks(codes, 5000, jitter_us=jitter_us, rng=random.Random(seed))
    return em.to_edges(marks, "omni", active_low=active_low)


class TestCleanStreams:
    def test_every_dock_code_comes_out_in_order(self) -> None:
        """A clean stream of the home base's codes decodes to exactly those codes."""
        codes, dec = decode(stream(DOCK_CODES))
        assert codes == DOCK_CODES
        assert dec.stats.errors == 0

    def test_real_roomba_remote_timings_decode(self) -> None:
        """Durations as a Flipper captured a Roomba remote's Forward (130) decode to 130."""
        from drivers.dock_ir.flipper import signal_edges

        durations = [2989, 1021, 975, 2997, 946, 3028, 915, 2997, 946, 2997, 946, 2999, 2909,
                     1024, 975, 21152, 2960, 1022, 975, 2999, 945, 3003, 941, 2999, 944, 3029,
                     915, 3000, 2909, 1027, 973]
        codes, dec = decode(signal_edges(durations))
        assert codes == [130, 130]
        assert dec.stats.errors == 0

    def test_active_high_receivers_decode_when_told(self) -> None:
        """With active_low False a mark is a high level; the same stream read wrong is lost."""
        edges = stream([164, 168], active_low=False)
        assert decode(edges, EdgeDecoder(active_low=False))[0] == [164, 168]
        assert decode(edges, EdgeDecoder(active_low=True))[0] == []

    def test_a_frame_waits_for_its_gap(self) -> None:
        """The 8th mark alone does not give the code: flush after the gap does."""
        edges = stream([161])
        dec = EdgeDecoder()
        assert [dec.feed(e.level, e.t_us) for e in edges] == [None] * len(edges)
        assert dec.flush(edges[-1].t_us + 1000) is None
        assert dec.flush(edges[-1].t_us + dec.gap_us + 1) == 161


class TestDamagedStreams:
    def test_jitter_of_150_us_loses_nothing(self) -> None:
        """Every pulse width off by up to 150 us: all 400 codes right, no error."""
        codes = [random.Random(7).choice(DOCK_CODES) for _ in range(400)]
        out, dec = decode(stream(codes, jitter_us=150, seed=3))
        assert out == codes
        assert dec.stats.errors == 0

    def test_dropped_edges_are_counted_never_misread(self) -> None:
        """2 % of edges left out: the frames hit are counted, the rest decode, none is wrong."""
        rng = random.Random(11)
        codes = [rng.choice(DOCK_CODES) for _ in range(500)]
        out, dec = decode(em.drop(stream(codes, jitter_us=150, seed=4), 0.02, rng))
        assert set(out) <= set(codes)
        assert _is_subsequence(out, codes)
        assert dec.stats.dropped_edges > 0
        assert len(out) + dec.stats.errors >= 0.9 * len(codes)

    def test_a_lost_mark_start_is_recovered(self) -> None:
        """Without the 3rd mark's start the frame still decodes (the space before is known)."""
        edges = stream([172, 172], jitter_us=150)
        del edges[4]  # the 3rd mark's start
        out, dec = decode(edges)
        assert out == [172, 172]
        assert dec.stats.recovered_edges == 1 and dec.stats.errors == 0

    def test_a_lost_mark_end_loses_only_that_frame(self) -> None:
        """Without a mark's end the bit is unknowable: the frame is counted, the next decodes."""
        edges = stream([165, 169])
        del edges[5]  # the 3rd mark's end
        out, dec = decode(edges)
        assert out == [169]
        assert dec.stats.dropped_edges == 1

    def test_a_lost_first_mark_start_keeps_the_frame_before(self) -> None:
        """The next frame's first mark start lost: the whole frame before it still counts."""
        edges = stream([161, 164, 168])
        del edges[16]  # the second frame's first mark start
        out, _dec = decode(edges)
        assert out == [161, 168]

    def test_two_emitters_colliding_give_no_wrong_code(self) -> None:
        """Two emitters overlapping at random offsets: collisions counted, no invented code."""
        rng = random.Random(5)
        wrong = 0
        for _ in range(300):
            a, b = rng.sample(DOCK_CODES, 2)
            ma, _ = em.code_marks(a, 10_000)
            mb, _ = em.code_marks(b, 10_000 + rng.randrange(300, 30_000))
            out, _dec = decode(em.to_edges(em.union(ma, mb), "omni"))
            wrong += sum(1 for c in out if c not in (a, b))
        assert wrong == 0

    def test_collisions_are_counted_as_such(self) -> None:
        """A second emitter starting mid-frame shows up in the collisions counter."""
        ma, _ = em.code_marks(164, 10_000)
        mb, _ = em.code_marks(168, 10_000 + 6_500)
        out, dec = decode(em.to_edges(em.union(ma, mb), "omni"))
        assert out == []
        assert dec.stats.collisions == 1

    def test_noise_spikes_are_glitches(self) -> None:
        """Short spikes in a stream cost only the frames they land in, and count as glitches."""
        codes = [161] * 50
        marks, end = em.stream_marks(codes, 0, rng=random.Random(2))
        noisy = em.union(marks, em.spikes(0, end, 20, width_us=200, rng=random.Random(9)))
        out, dec = decode(em.to_edges(noisy, "omni"))
        assert set(out) <= {161}
        assert len(out) >= 30
        assert dec.stats.glitches + dec.stats.collisions > 0

    def test_half_codes_are_counted(self) -> None:
        """A frame cut after 5 bits and then quiet is a half code, not a code."""
        marks, _ = em.code_marks(164, 0)
        out, dec = decode(em.to_edges(marks[:5], "omni"))
        assert out == []
        assert dec.stats.half_codes == 1

    def test_nine_bits_without_a_gap_are_refused(self) -> None:
        """A 9th mark before the gap (frames run together) loses the frame."""
        a, end = em.code_marks(161, 0)
        b, _ = em.code_marks(161, end + 1000)
        out, dec = decode(em.to_edges(a + b, "omni"))
        assert out == []
        assert dec.stats.collisions >= 1

    def test_a_stream_joined_mid_frame_resyncs_at_the_gap(self) -> None:
        """Edges seen from the middle of a frame: that frame is lost, the next ones decode."""
        edges = stream([168, 168, 168])[7:]
        out, _dec = decode(edges)
        assert out == [168, 168]

    def test_a_clock_stepping_back_is_counted(self) -> None:
        """An edge stamped before the previous one loses the frame and is counted."""
        edges = stream([161, 161])
        edges[5] = IrEdge("omni", edges[5].level, edges[4].t_us - 10)
        out, dec = decode(edges)
        assert out == [161]
        assert dec.stats.clock_steps == 1


@settings(max_examples=300, deadline=None)
@given(code=st.integers(0, 255), jitter_us=st.integers(0, 150), seed=st.integers(0, 2**32))
def test_any_code_with_jitter_up_to_150_us_decodes_exactly(code: int, jitter_us: int,
                                                           seed: int) -> None:
    """Encode any code with every pulse off by <= 150 us: it decodes to itself, no error."""
    out, dec = decode(stream([code, code], jitter_us=jitter_us, seed=seed))
    assert out == [code, code]
    assert dec.stats.errors == 0


def _is_subsequence(sub: list[int], seq: list[int]) -> bool:
    it = iter(seq)
    return all(any(x == y for y in it) for x in sub)
