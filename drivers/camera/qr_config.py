"""The forward camera that reads customers' QR codes: the ``qr_camera`` config section.

A second camera beside the downward line-following one (``camera``), with the same sources.
"""

from __future__ import annotations

from hal.options import Option, Section

QR_CAMERA = Section("qr_camera", "The forward camera for QR codes (drivers.camera.qr_reader).", (
    Option("source", "str", "uvc", "uvc: a USB camera; picamera: the Pi camera; file: a video.",
           choices=("uvc", "picamera", "file")),
    Option("device", "str", "/dev/video1", "V4L2 device of a USB camera (camera is video0)."),
    Option("file", "str", "", "Video file for source = file (a recorded customer)."),
    Option("loop", "bool", False, "Rewind the video file at its end."),
    Option("width", "int", 640, "Frame width (QR decoding needs ~3 px a module).",
           min=16, max=4096),
    Option("height", "int", 480, "Frame height.", min=16, max=4096),
    Option("fps", "float", 10.0, "Frames a second asked of the camera.", min=1, max=120),
))
