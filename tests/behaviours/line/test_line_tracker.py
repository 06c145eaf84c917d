"""The line tracker on recorded-style frames: what it must see and what it must refuse."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from behaviours.line.colours import parse_colour
from behaviours.line.scan import KERNEL_ENV, KERNELS
from behaviours.line.tracker import LineTracker, TrackerParams
from sim.devices.camera_model import CameraMount, SimCamera
from sim.world.body import DiffDriveBody
from sim.world.floor_plan import PaintedLine, World
from sim.world.geometry import Pose, segments_array

CENTRE_PX = 159.5


@pytest.fixture(autouse=True, params=KERNELS)
def kernel(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Every test runs with both ways of scanning the rows (behaviours/line/scan.py)."""
    name: str = request.param
    if name == "c" and importlib.util.find_spec("behaviours.line._line_scan") is None:
        pytest.skip("the C line scan was not built (tests/behaviours/test_line_scan.py fails)")
    monkeypatch.setenv(KERNEL_ENV, name)
    return name


def camera_over(*lines: PaintedLine, mount: CameraMount | None = None,
                floor_bgr: tuple[int, int, int] = (200, 205, 210)) -> SimCamera:
    world = World(6.0, 6.0, segments_array([]), lines=list(lines), floor_bgr=floor_bgr)
    return SimCamera(world, DiffDriveBody(world, Pose(1.0, 3.0, 0.0)), mount, seed=11)


def east(y_m: float, colour: str = "black", name: str = "l") -> PaintedLine:
    return PaintedLine(name, ((0.0, y_m), (6.0, y_m)), colour, 0.025)


def frame_at(camera: SimCamera, offset_m: float, heading_deg: float = 0.0) -> np.ndarray:  # type: ignore[type-arg]
    """The robot `offset_m` left of y = 3 (the line then appears right of centre)."""
    return camera.render(Pose(1.0, 3.0 + offset_m, math.radians(heading_deg)), (0.3, 0.3))


def px(camera: SimCamera, metres: float) -> float:
    return metres / camera.mount.m_per_px


class TestFindsTheLine:
    @settings(max_examples=25, deadline=None)
    @given(offset_m=st.floats(-0.1, 0.1), heading_deg=st.floats(-15, 15))
    def test_error_matches_where_the_line_is(self, offset_m: float, heading_deg: float) -> None:
        """Wholly in view, the error is the line's true offset at the ROI within 3 px."""
        camera = camera_over(east(3.0))
        pose = Pose(1.0, 3.0 + offset_m, math.radians(heading_deg))
        reading = LineTracker().track(camera.render(pose))
        roi_row = (0.25 + 0.6) / 2 * camera.height_px
        # Where the line crosses the middle ROI row: intersect y = 3 with that image row.
        fwd = camera.mount.forward_m + (camera.height_px / 2 - roi_row) * camera.mount.m_per_px
        ahead_x, ahead_y = pose.to_world(fwd, 0.0)
        left_m = (ahead_y - 3.0) / math.cos(pose.heading_rad)
        truth = px(camera, left_m)
        if abs(truth) > 110:  # partly out of view: see the at-edge test
            return
        assert not reading.lost
        assert reading.error_px == pytest.approx(truth, abs=3.0)
        del ahead_x

    def test_a_line_at_the_image_edge_is_reported_at_the_edge(self) -> None:
        """Half out of view on the right: found, at_edge, a large error, lower confidence."""
        camera = camera_over(east(3.0))
        reading = LineTracker().track(frame_at(camera, 0.12))
        assert not reading.lost
        assert reading.at_edge
        assert reading.error_px > 140
        assert reading.confidence < 0.7

    def test_uneven_light_does_not_move_the_line(self) -> None:
        """A strong light gradient and vignette: same error as under even light."""
        even = camera_over(east(3.0), mount=CameraMount(vignette=0.0, light_gradient=0.0,
                                                        ambient_variation=0.0))
        uneven = camera_over(east(3.0), mount=CameraMount(vignette=0.5, light_gradient=0.6,
                                                          ambient_variation=0.3))
        a = LineTracker().track(frame_at(even, 0.05))
        b = LineTracker().track(frame_at(uneven, 0.05))
        assert not b.lost
        assert b.error_px == pytest.approx(a.error_px, abs=2.0)

    @pytest.mark.parametrize("colour", ["red", "green", "blue", "yellow", "white", "black"])
    def test_every_paint_colour_is_found_when_asked_for(self, colour: str) -> None:
        """Each world paint is found by its FollowColor name, where it is.

        A white line is laid on a mid-grey floor: on the light default floor the lit parts of
        a white line clip at 255, as in a real camera, and barely stand out.
        """
        floor = (110, 115, 120) if colour == "white" else (200, 205, 210)
        camera = camera_over(east(3.0, colour), floor_bgr=floor)
        reading = LineTracker(colour=colour).track(frame_at(camera, -0.04))
        assert not reading.lost, reading.reason
        assert reading.error_px == pytest.approx(px(camera, -0.04), abs=3.0)

    def test_a_640_by_480_frame_gives_the_same_answer_in_its_pixels(self) -> None:
        """Wider frames are read at a column step; the error is still in full-size pixels."""
        camera = camera_over(east(3.0), mount=CameraMount(width_px=640, height_px=480))
        reading = LineTracker().track(frame_at(camera, 0.03))
        assert reading.error_px == pytest.approx(px(camera, 0.03), abs=3.0)

    def test_the_position_is_the_mean_over_the_rows_at_their_mean_row(self) -> None:
        """A slanted line: the position and the row it refers to lie on the line."""
        image = synthetic(slope=0.2)
        reading = LineTracker().track(image)
        assert reading.x_px == pytest.approx(LEFT_PX + 9.5 + 0.2 * reading.row_px, abs=0.05)

    def test_one_row_cut_short_does_not_pull_the_position(self) -> None:
        """Glare hides half the line in one scan row: that row is outvoted, not averaged in."""
        image = synthetic(slope=0.0)
        p = TrackerParams()
        scan_rows = np.linspace(int(p.roi_top * 240), int(p.roi_bottom * 240) - 1, p.rows)
        image[int(scan_rows[3]), LEFT_PX:LEFT_PX + 10] = 200
        assert LineTracker(p).track(image).x_px == pytest.approx(LEFT_PX + 9.5, abs=0.05)


    @pytest.mark.parametrize("width", [641, 1280, 1300, 1640, 2592])
    def test_wide_frames_are_read_averaged_down_and_placed_back_exactly(self,
                                                                       width: int) -> None:
        """Frames over 640 px are averaged down to at most 640 columns; the position is
        mapped back by the true ratio (1640 / 547, not 3): a stripe is where it is, to 0.05 px,
        at the left, middle and right (it was up to 1.8 px off at 1640 and 2592)."""
        for frac in (0.1, 0.5, 0.85):
            image = np.full((240, width, 3), 200, np.uint8)
            left = int(width * frac)
            image[:, left:left + 40] = 40
            assert LineTracker().track(image).x_px == pytest.approx(left + 19.5, abs=0.05)


LEFT_PX = 120


def synthetic(slope: float) -> np.ndarray:  # type: ignore[type-arg]
    """A light grey 320 x 240 frame with a 20 px dark line starting at LEFT_PX on row 0 and
    moving ``slope`` px right per row."""
    image = np.full((240, 320, 3), 200, np.uint8)
    for row in range(240):
        left = LEFT_PX + round(slope * row)
        image[row, left:left + 20] = 40
    return image


class TestRefuses:
    def test_bare_floor_is_lost(self) -> None:
        """No line in view: lost, zero confidence, a reason."""
        reading = LineTracker().track(frame_at(camera_over(), 0.0))
        assert reading.lost
        assert reading.confidence == 0.0
        assert reading.reason == "no line"

    def test_a_line_of_the_wrong_colour_is_lost(self) -> None:
        """Following black over a red line (and red over black): lost."""
        red = camera_over(east(3.0, "red"))
        black = camera_over(east(3.0, "black"))
        assert LineTracker(colour="black").track(frame_at(red, 0.0)).lost
        assert LineTracker(colour="red").track(frame_at(black, 0.0)).lost
        assert LineTracker(colour="green").track(frame_at(red, 0.0)).lost
        assert LineTracker(colour="blue").track(frame_at(black, 0.0)).lost

    def test_a_covered_lens_is_lost_as_too_dark(self) -> None:
        """A black frame is not one huge black line."""
        camera = camera_over(east(3.0))
        camera.cover()
        reading = LineTracker().track(frame_at(camera, 0.0))
        assert reading.lost
        assert reading.reason == "too dark"

    def test_a_half_black_frame_gives_no_infinities(self) -> None:
        """Black where the floor should be (a lens half covered): the line in the lit half is
        still found, and nothing in the black half divides by a zero floor."""
        image = synthetic(slope=0.0)
        image[:, 200:] = 0
        with np.errstate(all="raise"):
            reading = LineTracker().track(image)
        assert not reading.lost
        assert reading.x_px == pytest.approx(LEFT_PX + 9.5, abs=0.05)
        assert math.isfinite(reading.confidence)

    def test_a_frame_that_is_not_bgr_is_a_clear_error(self) -> None:
        """A grey image or an empty array: ValueError naming the shape."""
        with pytest.raises(ValueError, match="shape"):
            LineTracker().track(np.zeros((240, 320), np.uint8))
        with pytest.raises(ValueError, match="shape"):
            LineTracker().track(np.zeros((0, 0, 3), np.uint8))


class TestTwoLines:
    def test_two_lines_keep_the_one_nearest_the_previous_position(self) -> None:
        """A branch appears 6 cm left: the tracker stays on the line it was following."""
        camera = camera_over(east(3.0, name="main"), east(3.06, name="branch"))
        tracker = LineTracker()
        single = camera_over(east(3.0))
        first = tracker.track(frame_at(single, 0.04))
        second = tracker.track(frame_at(camera, 0.04))
        assert second.candidates == 2
        assert second.error_px == pytest.approx(first.error_px, abs=3.0)

    def test_two_lines_with_no_history_take_the_one_nearest_the_centre(self) -> None:
        """Fresh start between two lines: the nearer to the image centre wins."""
        camera = camera_over(east(3.0, name="near"), east(3.08, name="far"))
        reading = LineTracker().track(frame_at(camera, 0.02))
        assert reading.error_px == pytest.approx(px(camera, 0.02), abs=3.0)
        assert reading.confidence < 1.0


    def test_two_lines_are_never_mixed_into_a_position_between_them(self) -> None:
        """Turned so each line is nearer the centre in some rows: one line is reported."""
        camera = camera_over(east(3.0, name="a"), east(3.07, name="b"))
        pose = Pose(1.0, 3.026, math.radians(4.6))
        reading = LineTracker().track(camera.render(pose))
        mount = camera.mount
        fwd = mount.forward_m + (mount.height_px / 2 - reading.row_px - 0.5) * mount.m_per_px
        columns = [mount.width_px / 2 - 0.5 - ((y - pose.y_m - math.sin(pose.heading_rad) * fwd)
                                                / math.cos(pose.heading_rad)) / mount.m_per_px
                   for y in (3.0, 3.07)]
        assert reading.x_px is not None
        assert min(abs(reading.x_px - c) for c in columns) < 3.0

    def test_a_crossing_line_does_not_pull_the_position(self) -> None:
        """A same-colour line across the path fills some scan rows: those rows are dropped,
        the others still give the line's position."""
        crossing = PaintedLine("x", ((1.17, 0.0), (1.17, 6.0)), "black", 0.025)
        camera = camera_over(east(3.0), crossing)
        reading = LineTracker().track(frame_at(camera, 0.02))
        assert not reading.lost
        assert reading.error_px == pytest.approx(px(camera, 0.02), abs=3.0)
        assert reading.confidence < 1.0


class TestColours:
    def test_names_and_hex_codes_map_to_paints(self) -> None:
        """FollowColor may be a name in any case or #RRGGBB; None means the dark default."""
        assert parse_colour(None) == "black"
        assert parse_colour("Red") == "red"
        assert parse_colour("dark") == "black"
        assert parse_colour("#FF0000") == "red"
        assert parse_colour("#10C020") == "green"
        assert parse_colour("#202020") == "black"
        assert parse_colour("#F0F0F0") == "white"

    def test_an_unknown_colour_name_is_an_error_that_lists_the_known(self) -> None:
        """'purple' or '#XYZ': ValueError naming it and the choices."""
        with pytest.raises(ValueError, match=r"'purple'.*black"):
            parse_colour("purple")
        with pytest.raises(ValueError, match="#XYZ"):
            LineTracker(colour="#XYZ")

    def test_after_a_colour_change_the_old_line_is_followed_until_the_new_shows(self) -> None:
        """Handover: told 'red' while only black is in view, it keeps black for a while."""
        black = camera_over(east(3.0))
        red = camera_over(east(3.0, "red"))
        tracker = LineTracker(TrackerParams(handover_frames=3))
        tracker.track(frame_at(black, 0.0))
        tracker.set_colour("red")
        assert tracker.colour == "red"
        assert not tracker.track(frame_at(black, 0.0)).lost
        assert tracker.track(frame_at(red, 0.0)).colour == "red"
        assert tracker.track(frame_at(black, 0.0)).lost

    def test_the_handover_ends_after_its_frames(self) -> None:
        """With no red in sight, black counts only for handover_frames frames."""
        black = camera_over(east(3.0))
        tracker = LineTracker(TrackerParams(handover_frames=2))
        tracker.set_colour("red")
        image = frame_at(black, 0.0)
        assert [tracker.track(image).lost for _ in range(4)] == [False, False, True, True]


class TestParams:
    def test_a_region_of_interest_upside_down_is_refused(self) -> None:
        """roi_top must be above roi_bottom."""
        with pytest.raises(ValueError, match="ROI"):
            TrackerParams(roi_top=0.7, roi_bottom=0.3)

    def test_new_params_take_effect_at_once(self) -> None:
        """set_params with a band near the top of the image measures the line there."""
        camera = camera_over(east(3.0))
        image = camera.render(Pose(1.0, 3.0, math.radians(10)))
        tracker = LineTracker()
        low = tracker.track(image).error_px
        tracker.set_params(TrackerParams(roi_top=0.0, roi_bottom=0.2))
        high = tracker.track(image).error_px
        assert high > low + 10
