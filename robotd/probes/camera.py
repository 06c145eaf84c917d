"""``robotd probe camera``: open the camera with the real driver, measure it, look for the line.

    robotd probe camera                          # the [camera] section's source
    robotd probe camera --device /dev/video1 --width 640 --height 480
    robotd probe camera --source file --file run.avi --colour red
    robotd probe camera --save frame.png         # keep the last frame to look at

Prints frame size, measured frame rate, mean brightness, what the line tracker sees in the
last frame (error in pixels, confidence, or why it is lost) and how long the tracker takes on
it on this machine (and whether its row scan is the C one). ``--sim`` renders frames of a
straight line with the simulated camera instead of opening a device. Exit 0 when frames came
(even with no line in view), 1 when the camera is unavailable or delivered nothing.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import time
from typing import Any

import cv2

from behaviours.line.tracker import LineTracker, TrackerParams
from drivers.camera import CaptureCamera, open_camera
from hal.devices import DeviceUnavailable
from hal.readings import Frame
from robotd.config.errors import ConfigError
from robotd.config.loader import defaults, load_config
from robotd.probes import run_standalone, simulator


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="take the camera and line_follow sections from here")
    parser.add_argument("--source", choices=("uvc", "picamera", "file"))
    parser.add_argument("--device", help="V4L2 device path or index (uvc)")
    parser.add_argument("--file", help="video file (source file)")
    parser.add_argument("--width", type=int)
    parser.add_argument("--height", type=int)
    parser.add_argument("--fps", type=float)
    parser.add_argument("--frames", type=int, default=30, help="frames to read")
    parser.add_argument("--timeout-s", type=float, default=5.0, help="give up after this")
    parser.add_argument("--colour", help="line colour to look for (FollowColor name, #RRGGBB)")
    parser.add_argument("--save", help="write the last frame to this image file")
    parser.add_argument("--sim", action="store_true", help="the simulated camera over a line")
    parser.add_argument("--sim-offset-m", type=float, default=0.02,
                        help="simulated robot's offset to the left of the line")
    if "--json" not in parser._option_string_actions:
        parser.add_argument("--json", action="store_true", help="print one JSON object")


def _sections(args: argparse.Namespace) -> tuple[dict[str, Any], dict[str, Any]]:
    values = load_config(args.config) if args.config else defaults()
    camera = values["camera"]
    for key in ("source", "device", "file", "width", "height", "fps"):
        if getattr(args, key) is not None:
            camera[key] = getattr(args, key)
    return camera, values["line_follow"]


async def run(args: argparse.Namespace) -> int:
    try:
        camera_cfg, follow = _sections(args)
    except ConfigError as exc:
        print(f"probe camera: {exc}", file=sys.stderr)
        return 2
    try:
        tracker = LineTracker(TrackerParams(roi_top=follow["roi_top"],
                                            roi_bottom=follow["roi_bottom"],
                                            min_contrast=follow["min_contrast"]),
                              args.colour or follow["colour"])
    except ValueError as exc:
        print(f"probe camera: {exc}", file=sys.stderr)
        return 2
    try:
        if args.sim:
            report = await _measure_sim(args, camera_cfg)
        else:
            report = await _measure(open_camera(camera_cfg), args)
    except DeviceUnavailable as exc:
        print(f"probe camera: {exc}", file=sys.stderr)
        return 1
    last: Frame | None = report.pop("last")
    ended = report.pop("ended", None)
    if last is None or report["frames"] == 0:
        why = ended or f"no frames within {args.timeout_s:g} s"
        print(f"probe camera: {why}", file=sys.stderr)
        return 1
    reading = tracker.track(last.image)
    report["line"] = {"colour": reading.colour, "lost": reading.lost,
                      "tracker_kernel": tracker.kernel,
                      "tracker_ms": round(_tracker_ms(tracker, last.image), 3),
                      "error_px": None if reading.lost else round(reading.error_px, 1),
                      "confidence": round(reading.confidence, 2),
                      "width_px": round(reading.width_px, 1), "at_edge": reading.at_edge,
                      "candidates": reading.candidates, "reason": reading.reason}
    if args.save:
        cv2.imwrite(args.save, last.image)
        report["saved"] = args.save
    if args.json:
        print(json.dumps(report))
    else:
        _print(report)
    return 0


async def _measure(camera: CaptureCamera, args: argparse.Namespace) -> dict[str, Any]:
    loop = asyncio.get_running_loop()
    await camera.start()
    got = 0
    last = camera.latest()
    t0 = loop.time()
    ended: str | None = None
    try:
        async with asyncio.timeout(args.timeout_s):
            while got < args.frames:
                last = await camera.next_reading()
                got += 1
    except TimeoutError:
        pass
    except DeviceUnavailable as exc:  # a recording that ended, a camera that went away
        ended = str(exc)
    finally:
        elapsed_s = loop.time() - t0
        await camera.close()
    figures = _figures(camera.source, camera.width_px, camera.height_px, got, elapsed_s, last,
                       camera.status())
    figures["ended"] = ended
    return figures


async def _measure_sim(args: argparse.Namespace, camera_cfg: dict[str, Any]) -> dict[str, Any]:
    colour = args.colour if args.colour in ("black", "white", "red", "green", "blue",
                                            "yellow") else "black"
    camera = simulator().camera(colour, args.sim_offset_m, camera_cfg["width"],
                                camera_cfg["height"], camera_cfg["fps"])
    loop = asyncio.get_running_loop()
    await camera.start()
    t0 = loop.time()
    last = camera.latest()
    for _ in range(args.frames):
        last = await camera.next_reading()
    elapsed_s = loop.time() - t0
    await camera.close()
    return _figures("sim", camera.width_px, camera.height_px, args.frames, elapsed_s, last,
                    camera.status())


def _figures(source: str, width: int, height: int, frames: int, elapsed_s: float,
             last: Frame | None, status: dict[str, Any]) -> dict[str, Any]:
    return {"source": source, "width_px": width, "height_px": height, "frames": frames,
            "fps_measured": round(frames / elapsed_s, 2) if elapsed_s > 0 else None,
            "mean_brightness": None if last is None else round(float(last.image.mean()), 1),
            "failed_reads": status.get("failed_reads", 0), "last": last}


def _tracker_ms(tracker: LineTracker, image: Any, runs: int = 21) -> float:
    """The tracker's time on this frame on this machine: the median of ``runs`` in a row
    (warm caches; bench/bench_line_tracker.py times it cold, as after a capture)."""
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        tracker.track(image)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3


def _print(report: dict[str, Any]) -> None:
    print(f"{report['source']} camera: {report['width_px']}x{report['height_px']}, "
          f"{report['frames']} frames at {report['fps_measured']} FPS, mean brightness "
          f"{report['mean_brightness']}, failed reads {report['failed_reads']}")
    line = report["line"]
    print(f"tracker: {line['tracker_ms']} ms per frame, warm ({line['tracker_kernel']} row "
          "scan; right after a capture about twice that)")
    if line["lost"]:
        print(f"line ({line['colour']}): not found ({line['reason']})")
    else:
        edge = ", at the image edge" if line["at_edge"] else ""
        print(f"line ({line['colour']}): error {line['error_px']:+.1f} px, width "
              f"{line['width_px']} px, confidence {line['confidence']}, "
              f"{line['candidates']} candidate(s){edge}")
    if "saved" in report:
        print(f"last frame written to {report['saved']}")


def main(argv: list[str] | None = None) -> int:
    return run_standalone("robotd probe camera", __doc__, add_arguments, run, argv)


if __name__ == "__main__":
    sys.exit(main())
