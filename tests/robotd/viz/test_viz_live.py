"""``robotd sim --viz``: a Foxglove WebSocket client connects, subscribes and receives each channel.

The client speaks the Foxglove WebSocket protocol as the Foxglove app does: it offers the SDK's
subprotocol (``foxglove.sdk.v1``, the same protocol as ``foxglove.websocket.v1``, which it
offers too), reads ``serverInfo`` and ``advertise``, subscribes to every channel and counts the
binary ``messageData`` frames (opcode 1: subscription id, log time, payload) per topic.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import signal
import struct
import sys
from collections import Counter
from typing import Any

import pytest
import websockets

pytestmark = pytest.mark.slow

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
_MESSAGE_DATA = 0x01
_URL = re.compile(r"live view: (ws://[0-9.]+:\d+)")
_UNKNOWN = re.compile(r"Unknown channel ID: (\d+)")


async def _start_sim(*args: str) -> tuple[asyncio.subprocess.Process, str]:
    """A ``robotd sim ... --viz --viz-port 0`` and the URL it prints."""
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "robotd.cli", "sim", *args, "--viz", "--viz-port", "0",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert proc.stdout is not None
    async with asyncio.timeout(60):
        while True:
            line = (await proc.stdout.readline()).decode()
            assert line, "robotd sim ended before printing the live view's URL"
            found = _URL.search(line)
            if found:
                return proc, found.group(1)


async def _stop(proc: asyncio.subprocess.Process) -> None:
    if proc.returncode is None:
        proc.send_signal(signal.SIGINT)
        try:
            async with asyncio.timeout(30):
                await proc.wait()
        except TimeoutError:
            proc.kill()
            await proc.wait()


async def _subscribe(ws: Any, channel_ids: list[int], channels: dict[int, dict[str, Any]],
                     topic_of_sub: dict[int, str]) -> None:
    subs = []
    for channel_id in channel_ids:
        sub_id = len(topic_of_sub) + 1
        topic_of_sub[sub_id] = channels[channel_id]["topic"]
        subs.append({"id": sub_id, "channelId": channel_id})
    await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))


async def _receive(url: str, wanted: set[str], timeout_s: float) -> tuple[Counter[str],
                                                                          dict[str, Any]]:
    """Subscribe to every advertised channel until each wanted topic has a message."""
    counts: Counter[str] = Counter()
    channels: dict[int, dict[str, Any]] = {}
    topic_of_sub: dict[int, str] = {}
    info: dict[str, Any] = {}
    async with websockets.connect(url, subprotocols=SUBPROTOCOLS,  # type: ignore[arg-type]
                                  max_size=None) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_s):
                async for frame in ws:
                    if isinstance(frame, str):
                        op = json.loads(frame)
                        if op.get("op") == "serverInfo":
                            info = op
                        elif op.get("op") == "advertise":
                            for ch in op["channels"]:
                                channels[ch["id"]] = ch
                            await _subscribe(ws, [ch["id"] for ch in op["channels"]],
                                             channels, topic_of_sub)
                        elif op.get("op") == "status" and \
                                (unknown := _UNKNOWN.match(op["message"])) is not None:
                            # The SDK's server can refuse a subscription to a channel it
                            # advertised a moment before (a race while a client connects):
                            # this client asks again (a viewer that reconnects gets it).
                            await asyncio.sleep(0.2)
                            await _subscribe(ws, [int(unknown.group(1))], channels,
                                             topic_of_sub)
                        continue
                    if frame[0] == _MESSAGE_DATA:
                        sub_id, _log_time_ns = struct.unpack_from("<IQ", frame, 1)
                        counts[topic_of_sub[sub_id]] += 1
                        if wanted <= set(counts):
                            break
    info["schemas"] = {c["topic"]: c.get("schemaName") for c in channels.values()}
    return counts, info


async def _watch(scenario: str, wanted: set[str], *extra: str) -> tuple[Counter[str],
                                                                       dict[str, Any]]:
    proc, url = await _start_sim(scenario, "--speed", "4", *extra)
    try:
        return await _receive(url, wanted, timeout_s=90)
    finally:
        await _stop(proc)


class TestLiveView:
    async def test_nav_shows_map_scan_particles_path_and_state(self) -> None:
        """A viewer of the patrol robot gets the map, the scan, the particles, the path, the
        pose and the state, each in Foxglove's schema."""
        wanted = {"/map", "/scan", "/particles", "/path", "/pose", "/state", "/truth",
                  "/world/map"}
        counts, info = await _watch("nav", wanted, "--seed", "1")
        assert wanted <= set(counts), f"missing {wanted - set(counts)}; got {dict(counts)}"
        schemas = info["schemas"]
        assert schemas["/map"] == "foxglove.Grid"
        assert schemas["/scan"] == "foxglove.LaserScan"
        assert schemas["/particles"] == "foxglove.PosesInFrame"
        assert schemas["/path"] == "foxglove.SceneUpdate"
        assert info["name"].startswith("robotd sim nav")

    async def test_laundry_shows_the_camera_and_the_beacons(self) -> None:
        """A viewer of the laundry robot gets the camera frame, the line, the beacons' RSSI."""
        wanted = {"/camera", "/line", "/beacons", "/state"}
        counts, info = await _watch("laundry-loop", wanted, "--seed", "11")
        assert wanted <= set(counts), f"missing {wanted - set(counts)}; got {dict(counts)}"
        assert info["schemas"]["/camera"] == "foxglove.CompressedImage"


    @pytest.mark.parametrize(("scenario", "wanted"), [
        ("delivery", {"/map", "/scan", "/particles", "/path", "/pose", "/state"}),
        ("cabinet", {"/map", "/scan", "/pose", "/state", "/cabinet/links_open"}),
        ("docking", {"/dock", "/odom", "/state"}),
    ])
    async def test_every_robot_shows_what_it_has(self, scenario: str, wanted: set[str]) -> None:
        """The delivery, cabinet and docking robots each show their own channels live."""
        counts, _info = await _watch(scenario, wanted, "--seed", "1")
        assert wanted <= set(counts), f"missing {wanted - set(counts)}; got {dict(counts)}"


async def test_a_taken_port_is_exit_2() -> None:
    """A live view whose port is taken: ``robotd sim`` says so and exits 2."""
    import socket

    with socket.socket() as other:
        other.bind(("127.0.0.1", 0))
        other.listen()
        port = other.getsockname()[1]
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "robotd.cli", "sim", "square", "--viz", "--viz-port",
            str(port), stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
        out, _ = await asyncio.wait_for(proc.communicate(), 60)
    assert proc.returncode == 2
    assert f"live view on 127.0.0.1:{port}" in out.decode()
