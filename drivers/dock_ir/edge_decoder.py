"""One receiver's edges -> 8-bit beam codes, in the iRobot Open Interface IR framing.

A code is 8 bits, MSB first; bit 1 = 3 ms mark + 1 ms space, bit 0 = 1 ms mark + 3 ms space
(the OI's own timing; Flipper captures of Roomba remotes show the same, about 53 ms a frame
with the repeat gap). A frame is taken only whole: 8 marks, each with its space agreeing with
it (a 3 ms mark goes with a 1 ms space), then a space longer than any in a frame. Everything
else is counted and dropped, so a damaged frame is never taken for another code:

- a pulse shorter than a 0 bit's mark or space: a glitch (noise spike, dropout);
- a pulse out of tolerance at a frame's start: a glitch;
- out of tolerance, or mark and space disagreeing, after a bit was read: a collision (two
  emitters overlapping stretch the marks and shorten the spaces);
- a long gap before the 8th bit: a half code; a 9th mark before the gap: a collision;
- the same level twice: a dropped edge; a lost mark start is recovered (the space before
  it has a known width), a lost mark end loses the frame.

After a lost frame the decoder waits for the next long gap before it reads again.

Demodulating 38 kHz receivers (TSOP-style) pull their output LOW while they see the carrier:
a mark is a low level unless ``active_low`` is False.
"""

from __future__ import annotations

from drivers.dock_ir.stats import DecodeStats

BIT_MARK_ONE_US = 3000
BIT_MARK_ZERO_US = 1000
ONE_SPACE_US = 1000
ZERO_SPACE_US = 3000
FRAME_BITS = 8
INFERRED_MARGIN_US = 500  # an inferred mark width carries two pulses' jitter


def _nearest_bit(mark_us: int) -> int:
    """An inferred mark's bit: within 500 us of 3 ms -> 1, of 1 ms -> 0, else -1."""
    if abs(mark_us - BIT_MARK_ONE_US) <= INFERRED_MARGIN_US:
        return 1
    if abs(mark_us - BIT_MARK_ZERO_US) <= INFERRED_MARGIN_US:
        return 0
    return -1


class EdgeDecoder:
    """Feed it one receiver's edges in time order; it returns each code as it completes."""

    def __init__(self, *, active_low: bool = True, tolerance: float = 0.25,
                 stats: DecodeStats | None = None) -> None:
        if not 0 < tolerance < 0.5:
            # At 50 % the 1 ms and 3 ms windows meet and a bit could read either way.
            msg = f"tolerance must be between 0 and 0.5 (bit windows apart), got {tolerance}"
            raise ValueError(msg)
        self.mark_level = not active_low
        self.stats = stats if stats is not None else DecodeStats()
        self._short = (round(BIT_MARK_ZERO_US * (1 - tolerance)),
                       round(BIT_MARK_ZERO_US * (1 + tolerance)))
        self._long = (round(BIT_MARK_ONE_US * (1 - tolerance)),
                      round(BIT_MARK_ONE_US * (1 + tolerance)))
        self.gap_us = self._long[1]
        """A space longer than this ends a frame (no space inside one is as long)."""
        self._in_mark: bool | None = None
        self._last_t = 0
        self._synced = False
        self._bits = 0
        self._nbits = 0  # bits read, counting the one whose mark just ended
        self._bit = -1  # the bit of the mark that just ended, its space still to come

    @property
    def last_edge_us(self) -> int | None:
        """When the line last changed (None before its first edge since a reset)."""
        return None if self._in_mark is None else self._last_t

    def reset(self) -> None:
        """Forget the line's state (a new capture, a reopened line)."""
        self._in_mark = None
        self._synced = False
        self._start_frame()

    def feed(self, level: bool, t_us: int) -> int | None:
        """One edge (the level after it, its time); returns a code when this edge ends one."""
        self.stats.edges += 1
        mark = level == self.mark_level
        was_mark = self._in_mark
        if was_mark is None:
            # The line was quiet before the first edge we see: a mark begins a frame, a mark
            # ending means we came in mid-frame.
            self._in_mark, self._last_t = mark, t_us
            self._synced = mark
            self._start_frame()
            return None
        dt = t_us - self._last_t
        self._in_mark, self._last_t = mark, t_us
        if mark == was_mark:
            return self._edge_lost(mark, dt)
        if dt < 0:
            self.stats.clock_steps += 1
            self._lose()
            return None
        if mark:
            return self._space_ended(dt)
        self._mark_ended(dt)
        return None

    def flush(self, now_us: int) -> int | None:
        """The line has been quiet until ``now_us``: close a frame its gap has ended."""
        if self._in_mark is False and now_us - self._last_t > self.gap_us:
            code = self._gap()
            self._synced = True
            return code
        return None

    # --- the two kinds of pulse -------------------------------------------------------------
    def _mark_ended(self, mark_us: int) -> None:
        if not self._synced:
            return
        if self._nbits == FRAME_BITS:  # a 9th mark: the gap never came
            self.stats.collisions += 1
            self._lose()
            return
        bit = self._classify(mark_us)
        if bit < 0:
            self._count_bad(mark_us)
            self._lose()
            return
        self._bit = bit
        self._nbits += 1
        self._bits = (self._bits << 1) | bit

    def _space_ended(self, space_us: int) -> int | None:
        if space_us > self.gap_us:
            code = self._gap()
            self._synced = True  # this mark starts the next frame
            return code
        if not self._synced:
            return None
        if self._nbits == FRAME_BITS:
            return None  # the 9th mark is judged when it ends
        expected = 0 if self._bit == 1 else 1  # a 3 ms mark has a 1 ms space, and back
        if self._nbits == 0 or self._classify(space_us) != expected:
            self._count_bad(space_us)
            self._lose()
        return None

    def _gap(self) -> int | None:
        """A long space: the frame before it is complete, cut short, or there was none."""
        code: int | None = None
        if self._synced and self._nbits == FRAME_BITS:
            code = self._bits
            self.stats.codes += 1
        elif self._synced and self._nbits > 0:
            self.stats.half_codes += 1
        self._start_frame()
        return code

    def _edge_lost(self, mark: bool, dt: int) -> int | None:
        """The same level twice: the edge between was lost (a missed interrupt).

        A lost mark START is recoverable: from the last mark's end to this edge lie that bit's
        space, whose width its mark already fixed, and the next mark, so the next mark's width
        is the rest (two pulses' jitter in it, hence the wider window). A lost mark END hides
        whether the bit was 3 + 1 or 1 + 3 ms: that frame is lost.
        """
        if not mark and self._synced and dt >= 0:
            if self._nbits == FRAME_BITS and dt > self.gap_us:
                # The gap after a whole frame came, then a mark whose start we missed.
                self.stats.recovered_edges += 1
                code = self._gap()
                self._lose()  # the frame that mark began cannot be read
                return code
            if 0 < self._nbits < FRAME_BITS:
                space_us = ONE_SPACE_US if self._bit == 1 else ZERO_SPACE_US
                bit = _nearest_bit(dt - space_us)
                if bit >= 0:
                    self.stats.recovered_edges += 1
                    self._bit = bit
                    self._nbits += 1
                    self._bits = (self._bits << 1) | bit
                    return None
        self.stats.dropped_edges += 1
        self._lose()
        return None

    # --- helpers ----------------------------------------------------------------------------
    def _classify(self, width_us: int) -> int:
        """1 for a 3 ms pulse, 0 for a 1 ms one, -1 for neither."""
        if self._long[0] <= width_us <= self._long[1]:
            return 1
        if self._short[0] <= width_us <= self._short[1]:
            return 0
        return -1

    def _count_bad(self, width_us: int) -> None:
        if width_us < self._short[0] or self._nbits == 0:
            self.stats.glitches += 1
        else:
            self.stats.collisions += 1

    def _lose(self) -> None:
        """Drop the frame in progress and read nothing until the next long gap."""
        self._synced = False
        self._start_frame()

    def _start_frame(self) -> None:
        self._bits = 0
        self._nbits = 0
        self._bit = -1
