"""What the simulator's process sets for a run, and gives back after it.

One event loop simulates every device, robot and actor of a run, and the run allocates and frees
objects at a high rate: readings, commands, frames, futures and timer handles by the hundred
thousand.

- OpenCV's worker threads only add CPU on the simulated cameras' 320 x 240 frames (~5-10 % of
  `laundry`'s CPU, the same pixels either way).
- Python's cyclic collector, at its default gen-0 threshold of 700, runs ~570 young collections
  and a few full ones per `laundry` run (~0.35 s of ~6 s). Nearly all of the run's objects die by
  reference counting, so collecting young objects every 20 000 allocations instead finds the
  same garbage a little later, in a third of the time (bench/bench_sim.py; the behaviour is the
  same: no robot code depends on when a cycle is collected).

Both are process-wide, so only the simulator's runs take them, and each is given back after.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

import cv2

_GC_THRESHOLDS = (20_000, 20, 100)


@contextmanager
def simulator_process() -> Iterator[None]:
    """OpenCV on one thread and a lazier young-object collector while the block runs."""
    threads = cv2.getNumThreads()
    thresholds = gc.get_threshold()
    cv2.setNumThreads(1)
    gc.set_threshold(*_GC_THRESHOLDS)
    try:
        yield
    finally:
        gc.set_threshold(*thresholds)
        cv2.setNumThreads(threads)
