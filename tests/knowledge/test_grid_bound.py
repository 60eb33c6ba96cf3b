"""The grid bound, the lazy A*'s heuristic, stays below the true length to the goal from any free
point, knows the walls (above the straight line behind a wall), and the lazy A* with it gives the
whole graph's length on every shipped world and on random halls, opening fewer corners."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, reject, settings
from hypothesis import strategies as st

from symrl.knowledge.grid_bound import KNIGHT_EXCESS, GridBound
from symrl.knowledge.lazy_search import LazySearch
from symrl.knowledge.path_checks import path_checker
from symrl.knowledge.tangent_graph import TangentGraph
from symrl.world import MapError, WorldMap, load_map
from symrl.world.worldmap import SUITES, builtin_maps, suite_maps

ONE_REGION = {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]}


def _ends(world):
    s = np.array((world.start.x, world.start.y), dtype=float)
    g = np.array((world.goal.x, world.goal.y), dtype=float)
    return s, g, float(world.goal.radius)


def _bound(world, r: float) -> GridBound:
    _, g, rg = _ends(world)
    return GridBound(world, r, g, rg)


def _room(obstacles: list, size: float, start, goal) -> dict:
    return {
        "name": "room",
        "boundary": [[0, 0], [size, 0], [size, size], [0, size]],
        "obstacles": obstacles,
        "start": {"x": start[0], "y": start[1], "heading": 0.0},
        "goal": {"x": goal[0], "y": goal[1], "radius": 0.4},
        "regions": ONE_REGION,
    }


def _square(x: float, y: float, h: float) -> list[list[float]]:
    return [[x - h, y - h], [x + h, y - h], [x + h, y + h], [x - h, y + h]]


def _true_length(world, r: float, p: np.ndarray) -> float | None:
    """The shortest length from ``p`` (the lazy search with the straight-line heuristic)."""
    _, g, rg = _ends(world)
    try:
        return float(LazySearch(path_checker(world, r), p, g, rg).run()[0])
    except ValueError:
        return None


def _free_points(world, r: float, n: int, seed: int) -> list[np.ndarray]:
    chk = path_checker(world, r)
    pts = world.segments.reshape(-1, 2)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    for _ in range(50 * n):
        p = lo + rng.random(2) * (hi - lo)
        if chk.point_ok(p):
            out.append(p)
        if len(out) == n:
            break
    return out


def _walls_hall(seed: int, count: int) -> dict:
    """Random pillars and long thin walls in a 15 m room."""
    rng = np.random.default_rng(seed)
    obstacles = [
        _square(x, y, h)
        for (x, y), h in zip(
            rng.uniform(2, 13, (count, 2)), rng.uniform(0.05, 0.6, count), strict=True
        )
    ]
    for _ in range(3):
        x, y = rng.uniform(2, 11, 2)
        if rng.random() < 0.5:
            obstacles.append([[x, y], [x + 4, y], [x + 4, y + 0.1], [x, y + 0.1]])
        else:
            obstacles.append([[x, y], [x + 0.1, y], [x + 0.1, y + 4], [x, y + 4]])
    return _room(obstacles, 15.0, (0.8, 0.8), (14.2, 14.2))


def _walls_world(seed: int, count: int) -> WorldMap:
    """:func:`_walls_hall` loaded; a draw whose walls close the goal off is not a map (refused)."""
    try:
        return load_map(_walls_hall(seed, count))
    except MapError:
        reject()


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), count=st.integers(0, 25), r=st.sampled_from((0.26, 0.32)))
def test_the_bound_never_exceeds_the_true_length_from_a_free_point(seed, count, r):
    world = _walls_world(seed, count)
    bound = _bound(world, 0.26)  # a bound at the smaller clearance serves the larger
    for p in _free_points(world, r, 6, seed):
        length = _true_length(world, r, p)
        if length is not None:
            assert bound.at(*p) <= length


@pytest.mark.parametrize("name", ["office", "ros_lab", "maze", "two_doors", "check/winding"])
def test_on_shipped_worlds_the_bound_stays_below_and_knows_the_walls(name):
    world = load_map(name)
    bound = _bound(world, 0.26)
    _, g, rg = _ends(world)
    above = 0
    for p in _free_points(world, 0.316, 12, 1):
        length = _true_length(world, 0.316, p)
        assert length is not None
        h = bound.at(*p)
        assert h <= length
        above += h > math.hypot(*(p - g)) - rg + 0.5
    assert above > 0  # somewhere the walls make the way longer than the straight line, and it knows


def test_behind_a_long_wall_the_bound_is_near_the_detour_not_the_straight_line():
    # a wall across the room from the west side to 1 m short of the east side: the goal just
    # behind it is 1 m away as the crow flies and about 18 m round the wall's end
    wall = [[0.0, 7.45], [14.0, 7.45], [14.0, 7.55], [0.0, 7.55]]
    world = load_map(_room([wall], 15.0, (1.0, 6.0), (1.0, 8.6)))
    length = _true_length(world, 0.316, np.array([1.0, 6.0]))
    h = _bound(world, 0.26).at(1.0, 6.0)
    assert length is not None and 26.0 < length < 28.0
    assert (1.0 - 0.05) / KNIGHT_EXCESS * length - 1.0 < h <= length


def test_the_knight_excess_is_the_worst_ratio_of_grid_to_straight_line():
    # the 16-neighbour moves' cheapest combination for each direction, against its length
    moves = [(1, 0), (2, 1), (1, 1)]
    worst = 1.0
    for (ax, ay), (bx, by) in zip(moves[:-1], moves[1:], strict=True):
        for t in np.linspace(0.0, 1.0, 4001):
            u, v = 1 - t, t
            x, y = u * ax + v * bx, u * ay + v * by
            worst = max(worst, (u * math.hypot(ax, ay) + v * math.hypot(bx, by)) / math.hypot(x, y))
    assert worst == pytest.approx(KNIGHT_EXCESS, abs=1e-9)


SHIPPED = builtin_maps() + [name for suite in SUITES for name in suite_maps(suite)]


def _lengths(world, r: float) -> tuple[float | None, float | None, LazySearch | None]:
    """(whole graph + Dijkstra, lazy A* with the grid bound) lengths, None where no path."""
    s, g, rg = _ends(world)
    chk = path_checker(world, r)
    try:
        graph = TangentGraph(chk, s, g, rg)
        graph.build()
        whole: float | None = float(graph.shortest_route()[0])
    except ValueError:
        whole = None
    search = LazySearch(chk, s, g, rg, bound=_bound(world, min(r, 0.26)))
    try:
        return whole, float(search.run()[0]), search
    except ValueError:
        return whole, None, None


@pytest.mark.parametrize("name", SHIPPED)
def test_with_the_bound_the_lazy_search_finds_the_whole_graphs_length(name):
    world = load_map(name)
    for r in (0.26, 0.316):
        s, _, _ = _ends(world)
        if not path_checker(world, r).point_ok(s):
            continue
        whole, lazy, _ = _lengths(world, r)
        assert (whole is None) == (lazy is None), (name, r)
        if whole is not None:
            assert lazy == pytest.approx(whole, rel=1e-9, abs=0), (name, r)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), count=st.integers(0, 30))
def test_on_random_walled_halls_the_bound_keeps_the_length_and_opens_fewer_corners(seed, count):
    world = _walls_world(seed, count)
    whole, lazy, search = _lengths(world, 0.316)
    assert (whole is None) == (lazy is None)
    if search is None:
        return
    assert lazy == pytest.approx(whole, rel=1e-9, abs=0)
    s, g, rg = _ends(world)
    plain = LazySearch(path_checker(world, 0.316), s, g, rg)
    plain.run()
    assert len(search.tables.tables) <= len(plain.tables.tables)


def test_on_a_hall_where_a_tangent_point_is_computed_twice_both_searches_agree():
    # corner 11's tangent from the goal centre and from its leg's rim cut differ in the last bit,
    # which the whole graph's node keys told apart: corner 11's arcs were cut there, and its
    # route went round corner 22 (19.525 m) where the lazy search's bitangent to corner 52 runs
    world = load_map(_walls_hall(286, 14))
    whole, lazy, _ = _lengths(world, 0.316)
    assert lazy is not None and lazy == pytest.approx(19.4044, abs=1e-4)
    assert whole == pytest.approx(lazy, rel=1e-9, abs=0)
