"""The row scan's two kernels (C and numpy) find the same runs, and refuse bad input alike."""

from __future__ import annotations

import importlib
import importlib.util
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from structlog.testing import capture_logs

from behaviours.line.colours import LineColour, line_colour
from behaviours.line.scan import KERNEL_ENV, CRowScan, NumpyRowScan, Run, built_kernel, row_scan
from behaviours.line.tracker import LineTracker
from sim.devices.camera_model import CameraMount, SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array

COLOURS = [line_colour(name) for name in ("black", "white", "red", "yellow", "cyan", "blue")]
C_BUILT = importlib.util.find_spec("behaviours.line._line_scan") is not None
# Without the C kernel only test_the_c_kernel_was_built fails; what needs the kernel skips.
needs_c = pytest.mark.skipif(not C_BUILT, reason="the C line scan was not built")


def assert_same(c: tuple[float, list[Run]], numpy: tuple[float, list[Run]]) -> None:
    """Same runs cell for cell; middles and masses as far as float rounding goes."""
    assert c[0] == pytest.approx(numpy[0], rel=1e-6)  # the mean floor (OpenCV: in float)
    assert [run[:3] for run in c[1]] == [run[:3] for run in numpy[1]]
    for a, b in zip(c[1], numpy[1], strict=True):
        assert a[3] == pytest.approx(b[3], abs=1e-6)
        assert a[4] == pytest.approx(b[4], rel=1e-5, abs=1e-5)  # numpy: a float32 sum


def rendered(width: int, colour: str, seed: int) -> list[np.ndarray]:  # type: ignore[type-arg]
    """Frames of a line of ``colour`` (and a black one beside it) at random poses, with the
    camera model's uneven light, noise and motion blur."""
    lines = [PaintedLine("l", ((0.0, 3.0), (6.0, 3.0)), colour, 0.025),
             PaintedLine("m", ((0.0, 3.08), (6.0, 3.08)), "black", 0.02)]
    world = World(6.0, 6.0, segments_array([]), lines=lines)
    mount = CameraMount(width_px=width, height_px=width * 3 // 4)
    camera = SimCamera(world, DiffDriveBody(world, Pose(1.0, 3.0, 0.0)), mount, seed=seed)
    rng = np.random.default_rng(seed)
    return [camera.render(Pose(float(rng.uniform(0.5, 5.0)), 3.0 + float(rng.uniform(-0.1, 0.1)),
                               math.radians(float(rng.uniform(-20, 20)))), (0.3, 0.3))
            for _ in range(6)]


def test_the_c_kernel_was_built() -> None:
    """scripts/bootstrap installs a C compiler and Python's headers, so here it must be."""
    try:
        importlib.import_module("behaviours.line._line_scan")
    except ImportError as exc:  # pragma: no cover - says what to do instead of a bare error
        pytest.fail(f"the C line scan was not built ({exc}): install gcc and python3-dev "
                    "(scripts/bootstrap does), then .venv/bin/pip install -e .")


@needs_c
@pytest.mark.parametrize("width", [320, 640, 100, 1280])
@pytest.mark.parametrize("colour", ["black", "white", "red", "green"])
def test_both_kernels_find_the_same_runs_in_camera_frames(width: int, colour: str) -> None:
    """Rendered frames (uneven light, noise, blur, a second line) at four widths, each read
    for every colour kind: the same runs from both kernels."""
    rows = list(range(width * 3 // 16, width * 9 // 20, max(1, width // 40)))
    c, numpy = CRowScan(), NumpyRowScan()
    for image in rendered(width, colour, seed=width):
        for follow in COLOURS:
            level = 3 * 0.2 * (1.5 if follow.kind == "dark" else 1.0)
            assert_same(c.scan(image, rows, follow, level), numpy.scan(image, rows, follow, level))


@needs_c
@settings(max_examples=60, deadline=None)
@given(width=st.integers(4, 200), rows=st.integers(1, 12), level=st.floats(0.01, 3.0),
       colour=st.sampled_from(COLOURS), seed=st.integers(0, 2**32 - 1),
       flat=st.booleans())
def test_both_kernels_agree_on_any_image(width: int, rows: int, level: float,
                                         colour: LineColour, seed: int, flat: bool) -> None:
    """Noise, flat grey, widths that do not split into equal blocks, a single row."""
    rng = np.random.default_rng(seed)
    image = (np.full((rows + 3, width, 3), rng.integers(0, 256), np.uint8) if flat
             else rng.integers(0, 256, (rows + 3, width, 3), dtype=np.uint8))
    picks = sorted(rng.choice(rows + 3, rows, replace=False).tolist())
    assert_same(CRowScan().scan(image, picks, colour, level),
                NumpyRowScan().scan(image, picks, colour, level))


@needs_c
def test_a_frame_that_is_a_view_is_read_as_it_shows() -> None:
    """Every other column of a bigger frame: the C kernel reads packed pixels, so it gets a
    copy, and answers as for the copy."""
    image = rendered(640, "black", seed=3)[0][:, ::2]
    rows = [100, 120, 140]
    black = line_colour("black")
    assert_same(CRowScan().scan(image, rows, black, 0.9),
                NumpyRowScan().scan(np.ascontiguousarray(image), rows, black, 0.9))


@needs_c
class TestBadInput:
    def test_the_kernel_refuses_images_it_cannot_read(self) -> None:
        """Not 3-channel uint8 with packed pixels, or too narrow, or a bad level, kind or
        radius: a ValueError that says what it expected."""
        from behaviours.line import _line_scan

        image = np.zeros((10, 32, 3), np.uint8)
        for bad in (np.zeros((10, 32), np.uint8), image.astype(np.float32),
                    image.astype(np.int8), image.astype(bool), np.zeros((10, 32, 4), np.uint8),
                    np.zeros((10, 3, 3), np.uint8)):
            with pytest.raises(ValueError, match="expected uint8 BGR rows"):
                _line_scan.scan(bad, [1], 0, 0, 7, 0.9, 24, 4, 1, 3)
        with pytest.raises(ValueError, match="level"):
            _line_scan.scan(image, [1], 0, 0, 7, 0.0, 24, 4, 1, 3)
        with pytest.raises(ValueError, match="kind"):
            _line_scan.scan(image, [1], 5, 0, 7, 0.9, 24, 4, 1, 3)
        with pytest.raises(ValueError, match="radius"):
            _line_scan.scan(image, [1], 0, 0, 7, 0.9, 24, 4, 2**30, 3)

    def test_the_kernel_takes_row_indices_and_nothing_else(self) -> None:
        """Any sequence of integer indices (numpy ints too) inside the image; floats, bools,
        sets and strings are refused naming the item, rows outside naming the image's rows."""
        from behaviours.line import _line_scan

        image = rendered(320, "black", seed=4)[0]
        black = line_colour("black")
        expected = NumpyRowScan().scan(image, [60, 80, 100], black, 0.9)
        for rows in ([60, 80, 100], (60, 80, 100), np.array([60, 80, 100]),
                     [np.int64(60), np.uint16(80), 100]):
            assert_same(CRowScan().scan(image, rows, black, 0.9), expected)  # type: ignore[arg-type]
        assert CRowScan().scan(image, [], black, 0.9) == (0.0, [])
        assert NumpyRowScan().scan(image, [], black, 0.9) == (0.0, [])
        for scan in (CRowScan(), NumpyRowScan()):  # the numpy kernel refuses alike
            with pytest.raises(IndexError, match=r"outside|rows -1"):
                scan.scan(image, [-1, 5], black, 0.9)
            with pytest.raises(IndexError, match=r"outside|240 rows"):
                scan.scan(image, [5, 240], black, 0.9)
            with pytest.raises(ValueError, match="level"):
                scan.scan(image, [5, 6], black, 0.0)
        with pytest.raises(IndexError, match=r"row 240 \(rows\[1\]\) outside the image's 0..239"):
            _line_scan.scan(image, [1, 240], 0, 0, 7, 0.9, 24, 40, 3, 3)
        with pytest.raises(IndexError, match="outside"):
            _line_scan.scan(image, [-1], 0, 0, 7, 0.9, 24, 40, 3, 3)
        for rows, what in (([1, 2.0], r"rows\[1\] is float"), ([True], r"rows\[0\] is bool"),
                           ({1, 2}, "sequence"), (3, "sequence"), ("12", "sequence")):
            with pytest.raises(TypeError, match=what):
                _line_scan.scan(image, rows, 0, 0, 7, 0.9, 24, 40, 3, 3)

    def test_the_environment_picks_the_kernel(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """ROBOTD_LINE_KERNEL, in any case; unset: C, since it was built; a value that cannot
        be used is logged and ignored."""
        monkeypatch.setenv(KERNEL_ENV, "numpy")
        assert built_kernel() == "numpy"
        assert LineTracker().kernel == "numpy"
        monkeypatch.setenv(KERNEL_ENV, "C")
        assert LineTracker().kernel == "c"
        monkeypatch.delenv(KERNEL_ENV)
        assert LineTracker().kernel == "c"
        with capture_logs() as logs:
            monkeypatch.setenv(KERNEL_ENV, "fortran")  # a typo: logged, and the built one used
            assert LineTracker().kernel == "c"
        assert logs == [{"event": "line_tracker.kernel_env_ignored", "log_level": "warning",
                         "value": "fortran", "using": "c",
                         "why": "expected one of c, numpy"}]
        with pytest.raises(ValueError, match="expected one of c, numpy"):
            row_scan("gpu")  # asked for in code: an error
