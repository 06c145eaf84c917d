"""The dock IR decoder: throughput, and how many codes survive a damaged signal.

Prints:
- throughput: edges decoded per second on one core (``EdgeDecoder.feed`` over a long clean
  stream of the home base's codes, best of 5 runs), and the same through the device's batch
  path (``DockIrReceivers.feed``: receiver lookup, window, listeners);
- for each damage (clean; +-150 us jitter on every pulse; jitter + 2 % dropped edges; jitter
  + 2 % drops + noise spikes; two emitters colliding at random offsets): the frames sent, the
  share decoded right, and the wrong codes accepted (a code that was not sent at that place).

    .venv/bin/python bench/bench_dock_ir.py [--frames 20000] [--seed 1]
"""

from __future__ import annotations

import argparse
import random
import time
from collections.abc import Callable

from drivers.dock_ir import DockIrReceivers
from drivers.dock_ir.edge_decoder import EdgeDecoder
from hal.ports import IrEdge
from sim.devices import ir_emitter as em

DOCK_CODES = [161, 164, 165, 168, 169, 172, 173, 162]


def _decode(edges: list[IrEdge]) -> tuple[list[tuple[int, int]], EdgeDecoder]:
    """(code, time of the edge that closed it) for every code, and the decoder."""
    decoder = EdgeDecoder()
    out = []
    for e in edges:
        code = decoder.feed(e.level, e.t_us)
        if code is not None:
            out.append((code, e.t_us))
    if edges:
        code = decoder.flush(edges[-1].t_us + 10**6)
        if code is not None:
            out.append((code, edges[-1].t_us + 10**6))
    return out, decoder


def throughput(frames: int, seed: int) -> tuple[float, float]:
    rng = random.Random(seed)
    marks, _ = em.stream_marks([rng.choice(DOCK_CODES) for _ in range(frames)], 0,
                               jitter_us=100, rng=rng)
    edges = em.to_edges(marks, "omni")
    pairs = [(e.level, e.t_us) for e in edges]

    def bare() -> None:
        decoder = EdgeDecoder()
        feed = decoder.feed
        for level, t in pairs:
            feed(level, t)

    def device() -> None:
        dev = DockIrReceivers(em.SimIrEdgeSource, receivers=("omni",))
        dev.on_code(lambda _r, _c, _t: None)
        for i in range(0, len(edges), 64):  # ~2 frames a batch, as the port delivers them
            dev.feed(edges[i:i + 64])

    return len(edges) / _best(bare), len(edges) / _best(device)


def _best(run: Callable[[], None], repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        run()
        times.append(time.perf_counter() - t0)
    return min(times)


def damaged(name: str, frames: int, seed: int, *, jitter_us: int = 0, drop: float = 0.0,
            spikes_per_s: float = 0.0) -> dict[str, float | int | str]:
    rng = random.Random(seed)
    codes = [rng.choice(DOCK_CODES) for _ in range(frames)]
    marks, end = em.stream_marks(codes, 0, jitter_us=jitter_us, rng=rng)
    ends = [m[1] for m in marks[7::8]]
    if spikes_per_s:
        marks = em.union(marks, em.spikes(0, end, round(spikes_per_s * end / 1e6), rng=rng))
    edges = em.drop(em.to_edges(marks, "omni"), drop, rng)
    out, decoder = _decode(edges)
    right = wrong = 0
    for code, t in out:
        # The code belongs to the last frame that ended a gap before the edge that closed it
        # (that edge may be the next frame's first mark, or a later one if that was lost).
        i = _last_before(ends, t - decoder.gap_us)
        if i >= 0 and codes[i] == code:
            right += 1
        else:
            wrong += 1
    s = decoder.stats
    return {"case": name, "frames": frames, "right_pct": 100 * right / frames, "wrong": wrong,
            "glitches": s.glitches, "half": s.half_codes, "collisions": s.collisions,
            "dropped": s.dropped_edges}


def collisions(frames: int, seed: int) -> dict[str, float | int | str]:
    """Two emitters, their frames overlapping at random offsets (0.3-30 ms)."""
    rng = random.Random(seed)
    wrong = taken = 0
    counted = {"glitches": 0, "half": 0, "collisions": 0}
    for _ in range(frames):
        a, b = rng.sample(DOCK_CODES, 2)
        ma, _ = em.code_marks(a, 10_000, jitter_us=100, rng=rng)
        mb, _ = em.code_marks(b, 10_000 + rng.randrange(300, 30_000), jitter_us=100, rng=rng)
        out, dec = _decode(em.to_edges(em.union(ma, mb), "omni"))
        counted["glitches"] += dec.stats.glitches
        counted["half"] += dec.stats.half_codes
        counted["collisions"] += dec.stats.collisions
        taken += len(out)
        wrong += sum(1 for code, _t in out if code not in (a, b))
    return {"case": "two emitters colliding", "frames": frames,
            "right_pct": 100 * (taken - wrong) / frames, "wrong": wrong, **counted,
            "dropped": 0}


def windows(frames: int, seed: int, window_s: float = 0.2) -> tuple[float, int]:
    """A receiver in one beam (its code repeated, +-150 us jitter, 2 % edges dropped), read as
    the driver publishes it: every 50 ms, the codes decoded within the window. Returns the
    share of readings that show exactly the beam's code, and the readings showing another."""
    rng = random.Random(seed)
    code = 164
    marks, end = em.stream_marks([code] * frames, 0, jitter_us=150, rng=rng)
    out, _dec = _decode(em.drop(em.to_edges(marks, "omni"), 0.02, rng))
    times = [t for _c, t in out]
    window_us = round(window_s * 1e6)
    right = wrong = total = 0
    for now in range(window_us, end, 50_000):
        lo, hi = _last_before(times, now - window_us) + 1, _last_before(times, now + 1)
        seen = {c for c, _t in out[lo:hi + 1]}
        total += 1
        right += seen == {code}
        wrong += bool(seen - {code})
    return 100 * right / total, wrong


def _last_before(starts: list[int], t: int) -> int:
    lo, hi = 0, len(starts)
    while lo < hi:
        mid = (lo + hi) // 2
        if starts[mid] < t:
            lo = mid + 1
        else:
            hi = mid
    return lo - 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    bare, device = throughput(args.frames, args.seed)
    print(f"throughput: decoder {bare / 1e6:.2f} M edges/s, device batch path "
          f"{device / 1e6:.2f} M edges/s (one core; 6 receivers at a dock need ~2 k/s)")
    rows = [
        damaged("clean", args.frames, args.seed),
        damaged("jitter +-150 us", args.frames, args.seed, jitter_us=150),
        damaged("jitter +-150 us, 2 % edges dropped", args.frames, args.seed, jitter_us=150,
                drop=0.02),
        damaged("jitter, 2 % drops, 5 spikes/s", args.frames, args.seed, jitter_us=150,
                drop=0.02, spikes_per_s=5),
        collisions(args.frames // 10, args.seed),
    ]
    right, wrong = windows(args.frames, args.seed)
    print(f"one beam read through the 0.2 s window (readings every 50 ms), +-150 us jitter, "
          f"2 % drops: {right:.2f} % of readings right, {wrong} showing a wrong code")
    print(f"{'case':<38} {'frames':>7} {'right %':>8} {'wrong':>6} {'glitch':>7} "
          f"{'half':>6} {'collis':>7} {'dropped':>8}")
    for r in rows:
        print(f"{r['case']:<38} {r['frames']:>7} {r['right_pct']:>8.2f} {r['wrong']:>6} "
              f"{r['glitches']:>7} {r['half']:>6} {r['collisions']:>7} {r['dropped']:>8}")
    print("two emitters: 'right %' is the pairs of which one code still came out whole (the "
          "rest are counted lost)")


if __name__ == "__main__":
    main()
