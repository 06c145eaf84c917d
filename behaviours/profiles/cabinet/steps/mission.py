"""What the cabinet robot's steps share: the site, the navigation stack, the drive controller,
the task in hand, the path, and the latest scan.

The blocks of the seed's init phase fill it in (``task_manager``: the task list;
``perceptor``: the map, the grid, the navigation stack; ``path_planner``: the node graph;
``drive_controller``: the PID controllers); the other phases read and update it.
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from behaviours.motion.odometry import Odometry, OdometryPose
from behaviours.nav.localisation.filter import UNCERTAIN
from behaviours.nav.localisation.motion_model import compose, inverse
from behaviours.nav.navigator import NavStack
from behaviours.nav.scan_match import ScanMatcher
from behaviours.profiles.cabinet.config import CabinetConfig
from behaviours.profiles.cabinet.site import Site
from behaviours.profiles.cabinet.steps.drive_control import DriveController
from behaviours.profiles.cabinet.task_list import Task, TaskList
from hal.readings import LidarScan
from hal.telemetry import Telemetry

FloatArray = npt.NDArray[np.float64]

BLOCKS = ("task_manager", "perceptor", "path_planner", "drive_controller")


@dataclass
class Mission:
    """The mission's shared state (one per profile instance)."""

    config: CabinetConfig
    odometry: Odometry
    base_dir: str | None = None
    block_modes: dict[str, str] = field(default_factory=dict)
    block_status: dict[str, str] = field(default_factory=dict)
    task_doc: Any = None
    tasks: TaskList | None = None
    site: Site | None = None
    nav: NavStack | None = None
    matcher: ScanMatcher | None = None
    drive: DriveController | None = None
    localised: asyncio.Event = field(default_factory=asyncio.Event)
    scan: LidarScan | None = None
    scans: int = 0
    # The task list as worked through.
    remaining: list[Task] = field(default_factory=list)
    current: Task | None = None
    done: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    # Relocate: the path, where on it, the last node reached and the one driven to.
    path: list[str] = field(default_factory=list)
    path_pos: int = 0
    last_node: str | None = None
    next_node: str | None = None
    blocked_reason: str = ""
    avoid_start: set[str] = field(default_factory=set)
    # Fitting: the local map (points in the odometry frame), the turn made, the best score.
    local_points: list[FloatArray] = field(default_factory=list)
    turned_rad: float = 0.0
    desired_heading_rad: float = 0.0
    desired_point: tuple[float, float] | None = None
    room_middle_tried: bool = False
    best_score: float = 0.0
    fits: int = 0

    def reset_blocks(self) -> None:
        """The task manager's first two actions: every block's mode and status to init."""
        self.block_modes = dict.fromkeys(BLOCKS, "init")
        self.block_status = dict.fromkeys(BLOCKS, "idle")

    def on_scan(self, scan: LidarScan) -> None:
        self.scan = scan
        self.scans += 1

    async def fresh_scan(self, timeout_s: float = 3.0) -> LidarScan | None:
        """The first scan that starts after now (the robot standing still), or None."""
        loop = asyncio.get_running_loop()
        start, until = loop.time(), loop.time() + timeout_s
        while loop.time() < until:
            scan = self.scan
            if scan is not None and scan.t_s > start + 0.15:
                return scan
            await asyncio.sleep(0.05)
        return None

    def map_pose(self) -> OdometryPose:
        assert self.nav is not None
        return self.nav.pose()

    def odom_pose(self) -> OdometryPose:
        return self.odometry.pose()

    def relocalise(self, x_m: float, y_m: float, theta_rad: float) -> None:
        """The fit's pose handed to the navigation stack: particles round it, the fused pose
        (correction x odometry) equal to it now."""
        nav = self.nav
        assert nav is not None
        o = self.odometry.pose()
        pose = np.array([x_m, y_m, theta_rad])
        nav.localiser.start_at(x_m, y_m, theta_rad, sigma_m=0.05, sigma_rad=math.radians(3))
        nav.localiser.correction = compose(pose, inverse(np.array([o.x_m, o.y_m, o.theta_rad])))
        nav.localiser.status = UNCERTAIN
        self.localised.set()

    def standoff_m(self, task: Task) -> float:
        return task.standoff_m if task.standoff_m is not None else self.config.standoff_m

    def status(self) -> dict[str, Any]:
        """The task list, the current path and the broken links (``robotctl status``)."""
        graph = self.site.graph if self.site is not None else None
        return {
            "tasks": [t.cabinet for t in self.remaining],
            "current_task": self.current.cabinet if self.current else None,
            "done": list(self.done),
            "skipped": list(self.skipped),
            "path": list(self.path),
            "path_pos": self.path_pos,
            "last_node": self.last_node,
            "next_node": self.next_node,
            "broken_links": [list(k) for k in graph.broken_links()] if graph else [],
            "link_resets": graph.resets_this_task if graph else 0,
        }


def show_graph(telemetry: Telemetry, m: Mission, *, with_path: bool = False) -> None:
    """The node graph for the live view: open links, broken links (and the path just made)."""
    if not telemetry.enabled or m.site is None:
        return
    graph = m.site.graph
    nodes = {n.name: (n.x_m, n.y_m) for n in graph.nodes.values()}
    links = sorted({(min(a, b), max(a, b)) for a, out in graph.links.items() for b in out})
    telemetry.graph("cabinet/links_open", nodes, [k for k in links if graph.is_open(*k)])
    telemetry.graph("cabinet/links_broken", nodes, [k for k in links if not graph.is_open(*k)],
                    warn=True)
    if with_path:
        telemetry.path("cabinet/path", [nodes[name] for name in m.path if name in nodes])
