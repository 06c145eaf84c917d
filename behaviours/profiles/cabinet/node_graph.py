"""The path planner's node graph (the seed's relocate phase): nodes around doors, in the
middle of rooms and in front of cabinets, links where the robot fits, A* over the open links.

A link exists where the straight line between two nodes keeps ``clearance_m`` (the robot's
radius plus a margin) from every wall, read from the distance field of the rasterised map, and
crosses no door unless it is that door's own pair of nodes (a door is passed only between its
two nodes, so closing it blocks exactly one link). ``break_link`` closes a link both ways (as a
closed lane in Open-RMF); ``reset_links`` opens them all again, at most ``max_resets`` times
per task (``begin_task``).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from behaviours.nav.distance_field import DistanceField
from behaviours.profiles.cabinet.site_map import Point, SiteMap, segments_cross

DOOR, ROOM, CABINET = "door", "room", "cabinet"


class NoPath(Exception):
    """No path over the open links; ``reason`` says why, ``broken`` what is closed."""

    def __init__(self, reason: str, broken: tuple[tuple[str, str], ...]) -> None:
        super().__init__(reason)
        self.reason = reason
        self.broken = broken


@dataclass(frozen=True, slots=True)
class Node:
    name: str
    """``door:<door>:a|b``, ``room:<room>``, ``cabinet:<cabinet>``."""
    kind: str
    x_m: float
    y_m: float
    source: str
    """The JSON path of what made it (``cabinets[2]``): where a problem with it is reported."""

    @property
    def point(self) -> Point:
        return (self.x_m, self.y_m)


def link_key(a: str, b: str) -> tuple[str, str]:
    return (a, b) if a <= b else (b, a)


@dataclass(slots=True)
class NodeGraph:
    nodes: dict[str, Node]
    links: dict[str, dict[str, float]]
    """Every link (both directions) with its length in metres, open or broken."""
    max_resets: int = 3
    broken: set[tuple[str, str]] = field(default_factory=set)
    resets_this_task: int = 0

    def neighbours(self, name: str) -> Iterable[tuple[str, float]]:
        """Open links out of a node."""
        for other, length in self.links.get(name, {}).items():
            if link_key(name, other) not in self.broken:
                yield other, length

    def has_link(self, a: str, b: str) -> bool:
        return b in self.links.get(a, {})

    def is_open(self, a: str, b: str) -> bool:
        return self.has_link(a, b) and link_key(a, b) not in self.broken

    def break_link(self, a: str, b: str) -> bool:
        """Close the link a-b both ways; False when there is no such open link."""
        if not self.is_open(a, b):
            return False
        self.broken.add(link_key(a, b))
        return True

    def begin_task(self) -> None:
        """A new task: the reset budget is full again (broken links stay broken)."""
        self.resets_this_task = 0

    def may_reset(self) -> bool:
        return bool(self.broken) and self.resets_this_task < self.max_resets

    def reset_links(self) -> int:
        """Open every broken link; how many were opened. Counts against the task's budget."""
        count = len(self.broken)
        self.broken.clear()
        self.resets_this_task += 1
        return count

    def cabinet_node(self, cabinet: str) -> str:
        return f"{CABINET}:{cabinet}"

    def create_path(self, start: str, cabinet: str) -> list[str]:
        """Node names from ``start`` to the cabinet's node over open links (A*, lengths in
        metres, straight-line heuristic); ``NoPath`` with the reason when there is none."""
        goal = self.cabinet_node(cabinet)
        for name, what in ((start, "start node"), (goal, "cabinet")):
            if name not in self.nodes:
                raise NoPath(f"unknown {what} {name!r}", self.broken_links())
        path = self._astar(start, goal)
        if path is not None:
            return path
        if self.broken:
            closed = ", ".join(f"{a}-{b}" for a, b in sorted(self.broken))
            reason = (f"no path from {start} to cabinet {cabinet!r} over the open links "
                      f"({len(self.broken)} broken: {closed})")
        else:
            reason = f"no path from {start} to cabinet {cabinet!r}: no links connect them"
        raise NoPath(reason, self.broken_links())

    def broken_links(self) -> tuple[tuple[str, str], ...]:
        return tuple(sorted(self.broken))

    def _astar(self, start: str, goal: str) -> list[str] | None:
        gx, gy = self.nodes[goal].point
        def h(name: str) -> float:
            node = self.nodes[name]
            return math.hypot(node.x_m - gx, node.y_m - gy)

        best = {start: 0.0}
        came: dict[str, str] = {}
        frontier = [(h(start), 0.0, start)]
        while frontier:
            _f, cost, name = heapq.heappop(frontier)
            if name == goal:
                path = [name]
                while path[-1] != start:
                    path.append(came[path[-1]])
                return path[::-1]
            if cost > best.get(name, math.inf):
                continue
            for other, length in self.neighbours(name):
                new = cost + length
                if new < best.get(other, math.inf):
                    best[other] = new
                    came[other] = name
                    heapq.heappush(frontier, (new + h(other), new, other))
        return None

    def components(self) -> list[set[str]]:
        """Connected groups of nodes over all links (open or broken), largest first."""
        seen: set[str] = set()
        groups = []
        for name in self.nodes:
            if name in seen:
                continue
            group, stack = {name}, [name]
            while stack:
                for other in self.links.get(stack.pop(), {}):
                    if other not in group:
                        group.add(other)
                        stack.append(other)
            seen |= group
            groups.append(group)
        return sorted(groups, key=len, reverse=True)

    def nearest_node(self, x_m: float, y_m: float, field: DistanceField,
                     clearance_m: float) -> str | None:
        """The nearest node the robot at (x, y) can drive to in a straight line, or None."""
        order = sorted(self.nodes.values(), key=lambda n: math.hypot(n.x_m - x_m, n.y_m - y_m))
        for node in order:
            if line_clear((x_m, y_m), node.point, field, clearance_m):
                return node.name
        return None


def build_nodes(site: SiteMap, *, standoff_m: float, door_node_m: float) -> list[Node]:
    """The seed's nodes: both sides of each door, each room's middle, each cabinet's front."""
    nodes = []
    for i, door in enumerate(site.doors):
        (mx, my), (nx, ny) = door.middle, door.normal()
        for side, sign in (("a", 1.0), ("b", -1.0)):
            nodes.append(Node(f"{DOOR}:{door.name}:{side}", DOOR, mx + sign * door_node_m * nx,
                              my + sign * door_node_m * ny, f"doors[{i}]"))
    for i, room in enumerate(site.rooms):
        x, y = room.centroid()
        nodes.append(Node(f"{ROOM}:{room.name}", ROOM, x, y, f"rooms[{i}]"))
    for i, cabinet in enumerate(site.cabinets):
        x, y = cabinet.front_point(standoff_m)
        nodes.append(Node(f"{CABINET}:{cabinet.name}", CABINET, x, y, f"cabinets[{i}]"))
    return nodes


def line_clear(a: Point, b: Point, field: DistanceField, clearance_m: float) -> bool:
    """Whether every point of the straight line a-b keeps ``clearance_m`` from the walls
    (sampled every half cell; the field is 0 off the map, so a line leaving it never clears)."""
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    steps = max(1, math.ceil(length / (field.grid.resolution_m / 2)))
    t = np.linspace(0.0, 1.0, steps + 1)
    distance = field.at_points(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
    return bool(np.all(distance >= clearance_m))


def build_graph(site: SiteMap, field: DistanceField, *, clearance_m: float, standoff_m: float,
                door_node_m: float, max_resets: int = 3) -> tuple[NodeGraph, list[str]]:
    """The graph, and problems as ``where: message`` (a node too near a wall, a node no link
    reaches): the map is unusable with any of them."""
    nodes = build_nodes(site, standoff_m=standoff_m, door_node_m=door_node_m)
    problems = []
    usable = []
    for node in nodes:
        clear_m = field.at(node.x_m, node.y_m)
        if clear_m < clearance_m:
            problems.append(f"{node.source}: its node {node.name} at ({node.x_m:.2f}, "
                            f"{node.y_m:.2f}) is {clear_m:.2f} m from a wall, less than the "
                            f"robot's radius + margin {clearance_m:.2f} m")
        else:
            usable.append(node)
    links: dict[str, dict[str, float]] = {n.name: {} for n in usable}
    for i, a in enumerate(usable):
        for b in usable[i + 1:]:
            if _may_link(site, a, b) and line_clear(a.point, b.point, field, clearance_m):
                length = math.hypot(a.x_m - b.x_m, a.y_m - b.y_m)
                links[a.name][b.name] = length
                links[b.name][a.name] = length
    graph = NodeGraph({n.name: n for n in usable}, links, max_resets)
    groups = graph.components()
    for group in groups[1:]:
        for name in sorted(group):
            node = graph.nodes[name]
            problems.append(f"{node.source}: node {name} is not connected to the rest of the "
                            f"graph (no straight line to it clears the walls by "
                            f"{clearance_m:.2f} m)")
    return graph, problems


def _may_link(site: SiteMap, a: Node, b: Node) -> bool:
    """A link through a door's gap only joins that door's own two nodes."""
    segment = (a.x_m, a.y_m, b.x_m, b.y_m)
    for door in site.doors:
        if segments_cross(segment, door.segment):
            own = f"{DOOR}:{door.name}:"
            return a.name.startswith(own) and b.name.startswith(own)
    return True
