"""The spatial index answers every per-step query as the plain walls do, on a map of many walls."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from symrl.world import load_map
from symrl.world.physics import RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.spatial import CellWalls, free_sides, walls_for


def hall(k: int = 9, thin: bool = True) -> dict:
    """A 12 m x 9 m hall with a k x 3 grid of pillars, an inner wall with a door, thin walls."""
    pillars = [
        box(1.5 + 1.2 * i, 2.0 + 2.0 * j, 1.8 + 1.2 * i, 2.3 + 2.0 * j)
        for i in range(k)
        for j in range(3)
    ]
    room = box(0, 0, 12, 9).difference(box(6.0, 7.5, 6.2, 9.0))  # a wall stub from the north
    free = room.difference(unary_union(pillars))
    doc = {
        "boundary": [list(p) for p in list(free.exterior.coords)[:-1]],
        "obstacles": [[list(p) for p in list(h.coords)[:-1]] for h in free.interiors],
        "start": {"x": 0.8, "y": 0.8, "heading": 0.0},
        "goal": {"x": 11.0, "y": 8.0, "radius": 0.4},
        "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
    }
    if thin:
        doc["segments"] = [[[3.0, 8.2], [5.0, 8.2]], [[9.0, 0.5], [9.0, 1.5]]]
    return doc


@pytest.fixture(scope="module")
def world():
    return load_map(hall())


@pytest.fixture(scope="module")
def index(world):
    return CellWalls(world.segments, free_sides(world), reach=5.26, near=0.96)


def test_free_sides_point_into_the_free_area(world):
    sides = free_sides(world)
    seg = world.segments
    mid = 0.5 * (seg[:, :2] + seg[:, 2:])
    normal = np.stack([-(seg[:, 3] - seg[:, 1]), seg[:, 2] - seg[:, 0]], axis=1)  # the left
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    probe = mid + 1e-3 * normal * np.where(sides == 0, 1, sides)[:, None]
    free = Polygon(world.boundary, [p.tolist() for p in world.obstacles])
    polygon_edges = sides != 0
    inside = np.array(
        [free.contains(Polygon(box(x - 1e-9, y - 1e-9, x + 1e-9, y + 1e-9))) for x, y in probe]
    )
    assert inside[polygon_edges].all()


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(0.3, 11.7),
    y=st.floats(0.3, 8.7),
    h=st.floats(-math.pi, math.pi),
)
def test_the_index_answers_as_the_plain_walls(world, index, x, y, h):
    if not world.in_free_area(x, y):
        return
    offsets = (2 * math.pi / 24) * np.arange(24)
    rays, sectors, clear = index.scan(x, y, h, offsets, 24, 5.26, 0.76)
    rays0, sectors0, clear0 = index.all.scan(x, y, h, offsets, 24, 5.26, 0.76)
    np.testing.assert_allclose(rays, rays0, rtol=0, atol=1e-9)
    assert clear == pytest.approx(clear0, abs=1e-12)
    assert (sectors is None) == (sectors0 is None)
    if sectors is not None:
        np.testing.assert_allclose(sectors, sectors0, rtol=0, atol=1e-9)
    for a in np.linspace(-math.pi, math.pi, 8, endpoint=False):
        x1, y1 = x + 0.2 * math.cos(a), y + 0.2 * math.sin(a)
        c1 = index.all.point_clearance(x1, y1)
        assert index.swept_disc_contact(x, y, x1, y1, 0.26, clear0, c1) == (
            index.all.swept_disc_contact(x, y, x1, y1, 0.26, clear0, c1)
        )


def test_cells_keep_fewer_walls_than_reach(world, index):
    index.scan(6.0, 4.5, 0.0, np.zeros(1), 24, 5.26, 0.76)
    within = index._tree.query(box(6.0, 4.5, 6.5, 5.0), predicate="dwithin", distance=5.26)
    assert 0 < index.cell_sizes()[-1] < 0.6 * len(within)


def test_many_walls_use_the_index_and_batches_match_one_robot(monkeypatch):
    world = load_map(hall(k=9))
    monkeypatch.setattr("symrl.world.spatial.INDEX_FROM", len(world.segments))
    robot = RobotConfig()
    assert isinstance(walls_for(world, 5.26, 0.96), CellWalls)
    batch = RobotBatch(world, robot, 3)
    one = RobotBatch(world, robot, 1)
    starts = np.array([[0.8, 0.8, 0.0], [11.0, 5.0, 2.0], [5.0, 1.0, 1.0]])
    rngs = [np.random.default_rng(i) for i in range(3)]
    batch.reset(np.arange(3), starts, rngs)
    alone = [np.random.default_rng(1)]
    one.reset(np.array([0]), starts[1:2], alone)
    turn = np.random.default_rng(7).uniform(-1, 1, (60, 3))
    for k in range(60):
        got = batch.step(turn[k], rngs)
        ref = one.step(turn[k, 1:2], alone)
        np.testing.assert_array_equal(got.true_pose[1], ref.true_pose[0])
        np.testing.assert_array_equal(got.sonar[1], ref.sonar[0])
        np.testing.assert_array_equal(got.ir[1], ref.ir[0])


def test_few_walls_keep_the_plain_walls():
    from symrl.world.geometry import Walls

    world = load_map("hailu2001")
    assert type(walls_for(world, 5.26, 0.96)) is Walls
