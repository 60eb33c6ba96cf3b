"""Per-row wall sets: each row's cast bitwise that of its own ``Walls``, by hand and by property."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.world.geometry import Walls
from symrl.world.wall_sets import WallSets

SQUARE = np.array([[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]], dtype=np.float64)
EAST_WALL = np.array([[2.0, -1.0, 2.0, 1.0]])


def test_each_row_sees_only_its_own_walls_by_hand():
    """Row 0 in the unit square, row 1 before a lone wall 2 m east: from (0.5, 0.5) east, row
    0 hits the square's east side at 0.5 m (wall 1), row 1 its wall at 1.5 m (wall 0 of its
    set, index 4 across the padded rows); west, row 1 sees nothing within range."""
    sets = WallSets([SQUARE, EAST_WALL])
    angles = np.array([[0.0, math.pi], [0.0, math.pi]])
    ranges, walls = sets.cast_many_walls(np.array([0.5, 0.5]), np.array([0.5, 0.5]), angles, 3.0)
    np.testing.assert_allclose(ranges, [[0.5, 0.5], [1.5, 3.0]])
    np.testing.assert_array_equal(walls, [[1, 3], [4, -1]])
    assert sets.n_walls == 4 and len(sets) == 2
    # the per-wall arrays are read by the returned index
    assert sets.ax[4] == 2.0 and sets.dy[4] == 2.0


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.integers(2, 12), min_size=1, max_size=6),
    seed=st.integers(0, 2**32 - 1),
)
def test_a_row_equals_its_own_walls_bitwise(sizes, seed):
    """Random sets of different sizes, poses and headings: row b's ranges and walls are
    exactly those of ``Walls(sets[b])`` cast alone (the wall index moved by b's first). Sets
    of two walls or more: a one-wall ``Walls`` takes numpy's dot path for its (1, 2) @ (2, 1)
    product, which rounds differently in the last bit."""
    rng = np.random.default_rng(seed)
    sets = [rng.uniform(-3, 3, (k, 4)) for k in sizes]
    stacked = WallSets(sets)
    b = len(sets)
    x, y = rng.uniform(-2, 2, b), rng.uniform(-2, 2, b)
    angles = rng.uniform(-4, 4, (b, 1)) + np.arange(24) * (2 * math.pi / 24)
    ranges, walls = stacked.cast_many_walls(x, y, angles, 3.2)
    for row, segments in enumerate(sets):
        alone, wall = Walls(segments).cast_many_walls(
            x[row : row + 1], y[row : row + 1], angles[row : row + 1], 3.2
        )
        np.testing.assert_array_equal(ranges[row], alone[0])
        np.testing.assert_array_equal(
            walls[row], np.where(wall[0] >= 0, wall[0] + row * stacked.n_walls, -1)
        )


@pytest.mark.parametrize(
    ("sets", "message"),
    [
        ([], "need at least one row"),
        ([np.zeros((0, 4))], "need at least one wall segment"),
        ([SQUARE, np.array([[0.0, 0.0, 0.0, 0.0]])], "row 1's segment 0 .* has zero length"),
        ([np.array([[0.0, 0.0, np.nan, 1.0]])], "must be finite"),
    ],
)
def test_bad_sets_are_named(sets, message):
    with pytest.raises(ValueError, match=message):
        WallSets(sets)


def test_rays_for_another_batch_are_refused():
    with pytest.raises(ValueError, match="3 rows of rays for 2 sets"):
        WallSets([SQUARE, SQUARE]).cast_many_walls(np.zeros(3), np.zeros(3), np.zeros((3, 4)), 3.0)
