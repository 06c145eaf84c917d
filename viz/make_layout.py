"""Writes viz/robotd-layout.json, the Foxglove layout for robotd's live view and recordings.

    .venv/bin/python viz/make_layout.py

Built with the SDK's own layout models (``foxglove.layouts``), so the file follows the format
the SDK ships. Left: a 3D panel in the ``map`` frame (the map and the world's walls as grids,
the scan, the particles, the planned path, the estimated and the true pose, the painted lines,
the beacons and the dock). Right: the line camera, the state machine's states over time, the
beacons' RSSI, the state and the log. Topics are a single robot's (``/scan``); with several
robots in one simulation they are ``/<robot>/scan``: add them in the panel's settings.
"""

from __future__ import annotations

from pathlib import Path

import foxglove.layouts as fl

OUT = Path(__file__).with_name("robotd-layout.json")
BEACONS = ("b1_1", "b1_101", "b1_102", "b1_103", "b1_104")
"""The built-in laundry scenarios' beacons (``/beacons.rssi_dbm.b<major>_<minor>``)."""


def layout() -> fl.Layout:
    topics: dict[str, fl.BaseRendererTopicSettings] = {
        "/world/map": fl.BaseRendererGridTopicSettings(visible=True),
        "/map": fl.BaseRendererGridTopicSettings(visible=True),
        "/scan": fl.BaseRendererLaserScanTopicSettings(visible=True, point_size=4,
                                                       color_mode="flat",
                                                       flat_color="#ff3b30"),
        "/particles": fl.BaseRendererPosesTopicSettings(visible=True, type="arrow",
                                                        arrow_scale=(0.15, 0.02, 0.02)),
        "/path": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        "/pose": fl.BaseRendererPoseTopicSettings(visible=True, type="arrow"),
        "/truth": fl.BaseRendererPoseTopicSettings(visible=True, type="axis"),
        "/world/places": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        "/cabinet/links_open": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        "/cabinet/links_broken": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
        "/cabinet/path": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
    }
    three_d = fl.ThreeDeePanel(title="map", config=fl.ThreeDeeConfig(
        follow_tf="map", follow_mode="follow-none", topics=topics))
    camera = fl.ImagePanel(title="line camera", config=fl.ImageConfig(
        image_mode=fl.ImageModeConfig(image_topic="/camera")))
    states = fl.StateTransitionsPanel(title="state", config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value="/state.state", label="state")]))
    rssi = fl.PlotPanel(title="beacons RSSI (dBm)", config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=f"/beacons.rssi_dbm.{b}") for b in BEACONS]))
    events = fl.RawMessagesPanel(title="events", config=fl.RawMessagesConfig(
        topic_path="/events"))
    logs = fl.LogPanel(title="log", config=fl.LogConfig(topic_to_render="/log"))
    right = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=2, content=camera),
        fl.SplitItem(proportion=1, content=states),
        fl.SplitItem(proportion=2, content=rssi),
        fl.SplitItem(proportion=2, content=fl.TabContainer(tabs=[
            fl.TabItem(title="log", content=logs),
            fl.TabItem(title="events", content=events)])),
    ])
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[
        fl.SplitItem(proportion=3, content=three_d),
        fl.SplitItem(proportion=2, content=right),
    ]))


if __name__ == "__main__":
    OUT.write_text(layout().to_json() + "\n")
    print(f"wrote {OUT}")
