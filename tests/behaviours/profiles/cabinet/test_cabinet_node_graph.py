"""The cabinet robot's node graph: links against walls and doors, break, reset, no path."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from cabinet_site_fixture import site_doc
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from behaviours.nav.distance_field import DistanceField
from behaviours.nav.grid import Grid
from behaviours.profiles.cabinet.map_reader import parse_site_map
from behaviours.profiles.cabinet.node_graph import NodeGraph, NoPath, build_graph, line_clear
from behaviours.profiles.cabinet.site_map import SiteMap, segments_cross

CLEARANCE_M = 0.30


def example() -> tuple[SiteMap, DistanceField, NodeGraph]:
    site = parse_site_map(site_doc(), "map.json")
    field = DistanceField(site.grid())
    graph, problems = build_graph(site, field, clearance_m=CLEARANCE_M, standoff_m=0.5,
                                  door_node_m=0.5, max_resets=2)
    assert problems == []
    return site, field, graph


class TestLinks:
    def test_nodes_are_the_seeds(self) -> None:
        """Two nodes per door, one per room middle, one in front of each cabinet."""
        site, _field, graph = example()
        kinds = [n.kind for n in graph.nodes.values()]
        assert kinds.count("door") == 2 * len(site.doors)
        assert kinds.count("room") == len(site.rooms)
        assert kinds.count("cabinet") == len(site.cabinets)
        assert graph.nodes["cabinet:c1"].point == pytest.approx((0.9, 1.0))

    def test_no_link_passes_through_a_wall(self) -> None:
        """Every link's straight line keeps the clearance; lab and store middles are not
        linked (the wall between them), and nothing crosses a wall segment."""
        site, field, graph = example()
        walls = site.solid_walls()
        for a, others in graph.links.items():
            for b in others:
                pa, pb = graph.nodes[a].point, graph.nodes[b].point
                assert line_clear(pa, pb, field, CLEARANCE_M)
                assert not any(segments_cross((*pa, *pb), w) for w in walls)
        assert not graph.has_link("room:lab", "room:store")

    def test_a_door_is_crossed_only_by_its_own_link(self) -> None:
        """The two nodes of a door are linked through it; no other link crosses it."""
        _site, _field, graph = example()
        assert graph.has_link("door:ab:a", "door:ab:b")
        assert not graph.has_link("room:lab", "door:ab:b")
        assert not graph.has_link("cabinet:c1", "door:ab:b")

    def test_a_narrow_door_gives_no_link(self) -> None:
        """A door narrower than the robot's clearance links nothing through it."""
        doc = site_doc()
        doc["doors"][0]["segment"] = [5, 1.8, 5, 2.2]
        site = parse_site_map(doc, "map.json")
        field = DistanceField(site.grid())
        graph, _problems = build_graph(site, field, clearance_m=CLEARANCE_M, standoff_m=0.5,
                                       door_node_m=0.5)
        assert not graph.has_link("door:ab:a", "door:ab:b")


class TestPaths:
    def test_shortest_path_through_the_door(self) -> None:
        """From the lab to c2 the path goes through door ab."""
        _site, _field, graph = example()
        assert graph.create_path("room:lab", "c2") == [
            "room:lab", "door:ab:a", "door:ab:b", "cabinet:c2"]

    def test_break_link_closes_both_directions(self) -> None:
        """A broken link is used neither way; the next path goes round by the hall."""
        _site, _field, graph = example()
        assert graph.break_link("door:ab:b", "door:ab:a")
        assert not graph.is_open("door:ab:a", "door:ab:b")
        path = graph.create_path("room:lab", "c2")
        assert "door:ab:a" not in path[1:]
        assert path[-3:] == ["door:b-hall:a", "door:b-hall:b", "cabinet:c2"]
        back = graph.create_path("cabinet:c2", "c1")
        assert ("door:ab:b", "door:ab:a") not in itertools.pairwise(back)
        assert not graph.break_link("door:ab:a", "door:ab:b")

    def test_no_path_while_broken_then_reset(self) -> None:
        """Breaking both ways in: NoPath names the broken links; a reset restores them."""
        _site, _field, graph = example()
        graph.break_link("door:ab:a", "door:ab:b")
        graph.break_link("door:b-hall:a", "door:b-hall:b")
        with pytest.raises(NoPath, match="2 broken") as info:
            graph.create_path("room:lab", "c2")
        assert info.value.broken == (("door:ab:a", "door:ab:b"),
                                     ("door:b-hall:a", "door:b-hall:b"))
        assert graph.may_reset()
        assert graph.reset_links() == 2
        assert graph.create_path("room:lab", "c2")[-1] == "cabinet:c2"

    def test_resets_are_bounded_per_task(self) -> None:
        """After max_resets resets in a task no more are allowed until the next task."""
        _site, _field, graph = example()
        for _ in range(2):
            graph.break_link("door:ab:a", "door:ab:b")
            assert graph.may_reset()
            graph.reset_links()
        graph.break_link("door:ab:a", "door:ab:b")
        assert not graph.may_reset()
        graph.begin_task()
        assert graph.may_reset()

    def test_no_path_with_nothing_broken(self) -> None:
        """An unreachable cabinet with nothing broken: NoPath says no links connect them."""
        _site, _field, graph = example()
        for other in list(graph.links["cabinet:c4"]):
            del graph.links[other]["cabinet:c4"]
        graph.links["cabinet:c4"] = {}
        with pytest.raises(NoPath, match="no links connect them") as info:
            graph.create_path("room:lab", "c4")
        assert info.value.broken == ()
        assert not graph.may_reset()

    def test_nearest_node_is_in_sight(self) -> None:
        """The robot's start joins the graph at the nearest node it can drive to straight."""
        _site, field, graph = example()
        assert graph.nearest_node(2.5, 2.0, field, 0.2) == "room:lab"
        assert graph.nearest_node(5.6, 2.0, field, 0.2) == "door:ab:b"


coord = st.floats(min_value=0.2, max_value=5.8, allow_nan=False)


def exact_clearance(a: tuple[float, float], b: tuple[float, float],
                    walls: list[tuple[float, float, float, float]]) -> float:
    t = np.linspace(0.0, 1.0, 400)
    px, py = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
    best = math.inf
    for x1, y1, x2, y2 in walls:
        dx, dy = x2 - x1, y2 - y1
        u = np.clip(((px - x1) * dx + (py - y1) * dy) / (dx * dx + dy * dy), 0, 1)
        best = min(best, float(np.hypot(px - x1 - u * dx, py - y1 - u * dy).min()))
    return best


class TestLinkProperty:
    @settings(max_examples=60, deadline=None)
    @given(wall=st.tuples(coord, coord, coord, coord), a=st.tuples(coord, coord),
           b=st.tuples(coord, coord))
    def test_a_clear_line_never_passes_through_a_wall(
            self, wall: tuple[float, float, float, float], a: tuple[float, float],
            b: tuple[float, float]) -> None:
        """Whatever the wall, a line judged clear keeps the clearance less the grid's
        quantisation (a cell's diagonal) from it: it never crosses or touches it."""
        assume(math.hypot(wall[2] - wall[0], wall[3] - wall[1]) > 0.1)
        walls = [(0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 4.0), (6.0, 4.0, 0.0, 4.0),
                 (0.0, 4.0, 0.0, 0.0), (wall[0], wall[1] * 4 / 6, wall[2], wall[3] * 4 / 6)]
        field = DistanceField(Grid.from_segments(walls, 0.05))
        a2, b2 = (a[0], a[1] * 4 / 6), (b[0], b[1] * 4 / 6)
        if line_clear(a2, b2, field, CLEARANCE_M):
            assert not segments_cross((*a2, *b2), walls[4])
            assert exact_clearance(a2, b2, walls) >= CLEARANCE_M - 0.05 * math.sqrt(2)
