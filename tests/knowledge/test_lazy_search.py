"""The planner's lazy A* gives the whole graph's length on every shipped world and on random
pillar halls (the whole graph, like its tables, makes one node of a tangent point computed
twice), plans a floor of over 2,000 corners, screens long lines by the walls near their ends
without changing an answer, and still refuses bad input in one line."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.lazy_search import LazySearch
from symrl.knowledge.path_checks import PathChecker, path_checker
from symrl.knowledge.planner import WHOLE_GRAPH_CORNERS, shortest_path
from symrl.knowledge.tangent_graph import TangentGraph
from symrl.world import load_map
from symrl.world.geometry import Walls
from symrl.world.map_checks import check_plannable
from symrl.world.worldmap import SUITES, builtin_maps, suite_maps

ONE_REGION = {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]}
CLEARANCES = (0.2, 0.316, 0.45)


def _ends(world):
    s = np.array((world.start.x, world.start.y), dtype=float)
    g = np.array((world.goal.x, world.goal.y), dtype=float)
    return s, g, float(world.goal.radius)


def _both(world, r: float) -> tuple[float | None, float | None]:
    """(whole graph + Dijkstra, lazy A*) lengths; None where there is no path."""
    s, g, rg = _ends(world)
    chk = path_checker(world, r)
    out: list[float | None] = []
    for make in (TangentGraph, LazySearch):
        try:
            if make is TangentGraph:
                graph = TangentGraph(chk, s, g, rg)
                graph.build()
                out.append(float(graph.shortest_route()[0]))
            else:
                out.append(float(LazySearch(chk, s, g, rg).run()[0]))
        except ValueError:
            out.append(None)
    return out[0], out[1]


def _hall(pillars: list[tuple[float, float, float]], size: float, start, goal) -> dict:
    """A square room with square pillars ``(x, y, half side)``."""
    return {
        "name": "hall",
        "boundary": [[0, 0], [size, 0], [size, size], [0, size]],
        "obstacles": [
            [[x - h, y - h], [x + h, y - h], [x + h, y + h], [x - h, y + h]] for x, y, h in pillars
        ],
        "start": {"x": start[0], "y": start[1], "heading": 0.0},
        "goal": {"x": goal[0], "y": goal[1], "radius": 0.4},
        "regions": ONE_REGION,
    }


SHIPPED = builtin_maps() + [name for suite in SUITES for name in suite_maps(suite)]


@pytest.mark.parametrize("name", SHIPPED)
def test_on_every_shipped_world_the_lazy_search_finds_the_whole_graphs_length(name):
    world = load_map(name)
    for r in CLEARANCES:
        s, _, _ = _ends(world)
        if not path_checker(world, r).point_ok(s):
            continue
        whole, lazy = _both(world, r)
        assert (whole is None) == (lazy is None), (name, r)
        if whole is not None:
            assert lazy == pytest.approx(whole, rel=1e-9, abs=0), (name, r)


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    count=st.integers(1, 40),
    r=st.sampled_from(CLEARANCES),
)
def test_on_random_pillar_halls_the_lengths_agree_and_the_path_keeps_clear(seed, count, r):
    rng = np.random.default_rng(seed)
    pillars = [
        (x, y, h)
        for (x, y), h in zip(
            rng.uniform(2, 13, (count, 2)), rng.uniform(0.05, 0.6, count), strict=True
        )
    ]
    world = load_map(_hall(pillars, 15.0, (0.8, 0.8), (14.2, 14.2)))
    whole, lazy = _both(world, r)
    assert (whole is None) == (lazy is None)
    if whole is None:
        return
    assert lazy == pytest.approx(whole, rel=1e-9, abs=0)
    s, g, rg = _ends(world)
    search = LazySearch(path_checker(world, r), s, g, rg)
    _, route = search.run()
    points = search.polyline(route)
    assert Walls(world.segments).clearance(points).min() >= r - 1e-4
    assert np.hypot(*(points[-1] - g)) <= rg + 1e-9
    assert np.hypot(*(points[0] - s)) == 0.0


def test_a_tangent_point_computed_twice_is_one_node_of_the_whole_graph():
    # the goal centre's tangent to a circle and the tangent from its leg's rim cut are one point,
    # computed twice: two floats a bit apart that the nodes' keys (12 decimals) may tell apart
    world = load_map(_hall([(5.0, 5.0, 0.5)], 10.0, (1.0, 1.0), (9.0, 9.0)))
    chk = path_checker(world, 0.316)
    ci = int(np.argmin(np.hypot(*(chk.walls.vertices - (5.5, 5.5)).T)))
    a = round(math.pi / 4, 12) + 5e-13  # the pillar's outer corner, facing away from it
    b = math.nextafter(a, -math.inf)
    node_a, node_b = chk.tangent_node(ci, a), chk.tangent_node(ci, b)
    assert node_a is not None and node_b is not None and node_a[1] != node_b[1]
    graph = TangentGraph(chk, *_ends(world))
    assert graph.add_tangent_node(ci, a) == graph.add_tangent_node(ci, b) == node_a[1]
    assert graph.arcs_on[ci] == [(a, node_a[1])]  # one node: the circle's arcs are not cut there


@pytest.mark.parametrize("angles", [(0.1, 6.0), (-3.0, 3.0), (-1.0, 1.0)])
def test_two_nodes_on_a_circle_are_joined_by_the_shorter_arc(angles):
    """Two nodes are neighbours both ways round their circle: the edge between them is the
    shorter arc (across the angles' seam at +-pi, or not), free or not checked against."""
    world = load_map(_hall([(5.0, 5.0, 0.5)], 10.0, (1.0, 1.0), (9.0, 9.0)))
    chk = path_checker(world, 0.316)
    graph = TangentGraph(chk, *_ends(world))
    graph.chk = SimpleNamespace(arcs_ok=lambda ci, arcs: [True] * len(arcs))  # every arc free
    a0, a1 = angles
    graph.arcs_on = {0: [(a1, "v"), (a0, "u")]}
    graph._add_arcs()
    gap = min(a1 - a0, 2 * math.pi - (a1 - a0))
    assert graph.graph["u"]["v"]["weight"] == pytest.approx(graph.r * gap)


def _big_hall(k: int) -> dict:
    pitch = 40.0 / (k + 1)
    pillars = [
        (i * pitch + 0.3 * pitch, j * pitch, 0.15) for i in range(1, k + 1) for j in range(1, k + 1)
    ]
    return _hall(pillars, 40.0, (0.6, 0.6), (39.0, 39.0))


def test_a_hall_of_over_2000_corners_is_planned_not_refused():
    world = load_map(_big_hall(23))
    assert len(world.segments) > 2000
    check_plannable(world)  # within the limit
    t0 = time.process_time()
    plan = shortest_path(world)
    assert time.process_time() - t0 < 10.0
    assert plan.method.endswith("A*")
    assert np.hypot(39.0 - 0.6, 39.0 - 0.6) - 0.4 <= plan.length < 60.0
    assert Walls(world.segments).clearance(plan.points).min() >= plan.clearance - 1e-4


def test_bad_input_on_a_big_map_still_gets_its_one_line_errors():
    # two rooms joined by a 0.6 m door (the body passes, a 0.316 m clearance does not), 40
    # pillars: the lazy search
    pillars = [(1.0 + 0.45 * i, 1.0 + 2.0 * j, 0.1) for i in range(10) for j in range(4)]
    doc = _hall(pillars, 10.0, (0.5, 0.5), (9.0, 9.0))
    doc["obstacles"].append([[0.0, 9.0], [8.0, 9.0], [8.0, 9.2], [0.0, 9.2]])
    doc["obstacles"].append([[8.6, 9.0], [10.0, 9.0], [10.0, 9.2], [8.6, 9.2]])
    doc["goal"] = {"x": 5.0, "y": 9.6, "radius": 0.2}
    world = load_map(doc)
    assert len(world.segments) > WHOLE_GRAPH_CORNERS
    with pytest.raises(
        ValueError, match="^no collision-free path from the start to the goal disc$"
    ):
        shortest_path(world)
    with pytest.raises(
        ValueError, match=r"^start \(1\.0, 1\.0\) is closer than 0\.316 m to a wall"
    ):
        shortest_path(world, start=(1.0, 1.0))


def test_the_near_walls_screen_refuses_only_what_the_full_check_refuses():
    # random long motions from the corners of a pillar hall, checked with and without the
    # screen (the walls near the corner, or near the start, crossed in numpy first)
    world = load_map(_big_hall(8))
    rng = np.random.default_rng(0)
    full, screened = PathChecker(world, 0.316), PathChecker(world, 0.316)
    corners = full.walls.vertices
    refused = 0
    for ci in rng.choice(len(corners), 40, replace=False).tolist():
        ang = rng.uniform(-np.pi, np.pi, 60)
        a = corners[ci] + 0.316 * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        b = rng.uniform(0.0, 40.0, (60, 2))
        want = full.segments_free(a, b)
        np.testing.assert_array_equal(screened.segments_free(a, b, around=ci), want)
        refused += int((~want).sum())
        near = screened.index.near_rings(a[0])
        for k in range(0, 60, 6):
            assert screened.segment_ok(a[k], b[k], near=near) == full.segment_ok(a[k], b[k])
    assert refused > 1000  # most long motions hit a pillar: the screen had work to do
