"""The planner's wall index answers every query as the full wall set does (bit for bit where a
distance is returned), on walls picked near the query only."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.wall_index import WallIndex
from symrl.world import load_map
from symrl.world.geometry import Walls

WALLS = {name: Walls(load_map(name).segments) for name in ("office", "maze", "hailu2001")}


def _points(world: str, seed: int, n: int = 400) -> np.ndarray:
    segments = WALLS[world].segments.reshape(-1, 2)
    lo, hi = segments.min(axis=0) - 0.5, segments.max(axis=0) + 0.5
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, 2))


@settings(max_examples=15, deadline=None)
@given(
    world=st.sampled_from(sorted(WALLS)),
    seed=st.integers(0, 2**32 - 1),
    r=st.sampled_from([0.1, 0.316, 0.45]),
)
def test_clearances_near_the_walls_are_the_full_sets_and_far_ones_stay_far(world, seed, r):
    walls, pts = WALLS[world], _points(world, seed)
    index = WallIndex(walls, r)
    full = walls.clearance(pts)
    near = full < r
    fast = index.points_clearance(pts)
    np.testing.assert_array_equal(fast[near], full[near])
    assert np.all(fast[~near] >= r)
    closest = np.array([walls.point_clearance(x, y) for x, y in pts])
    fast_closest = index.points_clearance_closest(pts)
    np.testing.assert_array_equal(fast_closest[closest < r], closest[closest < r])
    for (x, y), c in zip(pts[:60], closest[:60], strict=True):
        for limit in (0.5 * r, r):
            assert index.point_clearance_ge(x, y, limit) == (c >= limit)
