"""``robotd probe camera``: figures and line detection from the real drivers or the sim camera."""

from __future__ import annotations

import argparse
import asyncio
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from drivers.camera import UvcCamera, VideoFileCamera, from_settings
from robotd.config.loader import defaults
from robotd.config.settings import Settings
from robotd.probes import camera as probe
from sim import vclock


def _args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    probe.add_arguments(parser)
    return parser.parse_args(argv)


def _last_json(out: str) -> dict[str, object]:
    report: dict[str, object] = json.loads(out.strip().splitlines()[-1])
    return report


class TestCameraProbe:
    def test_sim_json_reports_size_rate_and_the_line(self, capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
        """--sim --json: 320x240 at 30 FPS, the line 2 cm right of centre (about 27 px)."""
        code = vclock.run(probe.run(_args(["--sim", "--json"])))
        report = _last_json(capsys.readouterr().out)
        assert code == 0
        assert (report["width_px"], report["height_px"]) == (320, 240)
        assert report["fps_measured"] == pytest.approx(30.0)
        line = report["line"]
        assert isinstance(line, dict)
        assert not line["lost"]
        assert line["error_px"] == pytest.approx(26.7, abs=2)
        assert line["tracker_kernel"] in ("c", "numpy")
        assert line["tracker_ms"] > 0

    def test_a_recorded_video_with_the_wrong_colour_says_lost(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A file of a black line probed for red: frames counted, line not found."""
        path = tmp_path / "black.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (320, 240))
        for _ in range(5):
            image = np.full((240, 320, 3), 200, np.uint8)
            image[:, 150:180] = 30
            writer.write(image)
        writer.release()
        argv = ["--source", "file", "--file", str(path), "--frames", "3", "--colour", "red",
                "--json", "--save", str(tmp_path / "last.png")]
        code = vclock.run(probe.run(_args(argv)))
        report = _last_json(capsys.readouterr().out)
        assert code == 0
        assert report["frames"] == 3
        line = report["line"]
        assert isinstance(line, dict)
        assert line["lost"] and line["colour"] == "red"
        assert (tmp_path / "last.png").exists()

    def test_a_recording_that_ends_at_once_says_so(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A one-image "recording" ends after its first frame: exit 1 saying it ended (not
        "no frames within 5 s", which sent technicians looking for a stalled camera)."""
        path = tmp_path / "still.png"
        cv2.imwrite(str(path), np.full((240, 320, 3), 200, np.uint8))
        code = vclock.run(probe.run(_args(["--source", "file", "--file", str(path)])))
        assert code == 1
        err = capsys.readouterr().err
        assert "end of recording after 1 frames" in err and "within" not in err

    def test_a_missing_camera_exits_1_with_one_line(self, capsys: pytest.CaptureFixture[str]
                                                    ) -> None:
        """No such V4L2 device: exit 1, the reason on stderr."""
        code = asyncio.run(probe.run(_args(["--device", "/dev/video97"])))
        assert code == 1
        assert "/dev/video97: cannot open" in capsys.readouterr().err

    def test_a_missing_camera_prints_no_opencv_warnings(self, capfd: pytest.CaptureFixture[str]
                                                        ) -> None:
        """OpenCV's own WARN lines (written by its C++ to fd 2) do not come before ours."""
        assert asyncio.run(probe.run(_args(["--device", "/dev/video97"]))) == 1
        err = capfd.readouterr().err
        assert "[ WARN" not in err
        assert err.startswith("probe camera: camera /dev/video97: cannot open")

    def test_an_unknown_colour_is_a_usage_error(self, capsys: pytest.CaptureFixture[str]
                                                ) -> None:
        """--colour purple: exit 2 naming it."""
        assert vclock.run(probe.run(_args(["--sim", "--colour", "purple"]))) == 2
        assert "purple" in capsys.readouterr().err


class TestFromSettings:
    def test_the_camera_section_picks_the_driver(self, tmp_path: Path) -> None:
        """camera.source uvc -> UvcCamera on camera.device; file -> VideoFileCamera."""
        settings = Settings(defaults())
        camera = from_settings(settings)
        assert isinstance(camera, UvcCamera)
        assert camera.device == "/dev/video0"
        settings.set("camera.source", "file")
        settings.set("camera.file", str(tmp_path / "run.avi"))
        assert isinstance(from_settings(settings), VideoFileCamera)
