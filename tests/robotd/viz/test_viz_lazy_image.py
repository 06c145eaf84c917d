"""An image handed to the live view as a function is drawn only when it is published."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
from mcap.reader import make_reader

from robotd.viz.session import VizSession
from robotd.viz.telemetry import FoxgloveTelemetry


class Drawer:
    """A frame that counts how often it is drawn."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> npt.NDArray[np.uint8]:
        self.calls += 1
        return np.full((24, 32, 3), 200, dtype=np.uint8)


def test_a_drawn_image_is_drawn_only_when_due(tmp_path: Path) -> None:
    """20 frames over 2 s, images at most every 1 s: drawn twice, 2 images recorded."""
    session = VizSession()
    t_ns = [0]
    feed = FoxgloveTelemetry(session.context, clock_ns=lambda: t_ns[0])
    session.record(tmp_path / "run.mcap")
    draw = Drawer()
    for i in range(20):
        t_ns[0] = 1_000_000_000 + i * 100_000_000
        feed.image("camera", draw, marks=[(5, 5)])
    session.close()
    with (tmp_path / "run.mcap").open("rb") as f:
        images = [m for _s, c, m in make_reader(f).iter_messages() if c.topic == "/camera"]
    assert draw.calls == 2 and len(images) == 2


def test_nothing_is_drawn_without_a_sink() -> None:
    """No viewer and no recording: the function is never called."""
    session = VizSession()
    try:
        feed = session.telemetry("r")
        draw = Drawer()
        feed.image("camera", draw)
        assert draw.calls == 0 and feed.published == 0
    finally:
        session.close()
