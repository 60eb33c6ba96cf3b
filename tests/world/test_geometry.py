"""Geometry against hand-computed distances and a brute-force sampling of the walls."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from symrl.world import load_map
from symrl.world.geometry import (
    Walls,
    clearance,
    ray_cast,
    sector_distances,
    swept_disc_contact,
)

SQUARE = np.array(  # the unit square [0, 1]^2, counter-clockwise
    [[0, 0, 1, 0], [1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 0, 0]], dtype=np.float64
)


@pytest.fixture(scope="module")
def walls() -> Walls:
    return Walls(load_map("hailu2001").segments)


def brute_sectors(segments: np.ndarray, x: float, y: float, h: float, n: int, cap: float):
    """Sector minima by sampling every wall densely (an upper bound within ~1e-3 m)."""
    t = np.linspace(0.0, 1.0, 5001)
    px = (segments[:, 0, None] * (1 - t) + segments[:, 2, None] * t).ravel()
    py = (segments[:, 1, None] * (1 - t) + segments[:, 3, None] * t).ravel()
    d = np.hypot(px - x, py - y)
    rel = np.mod(np.arctan2(py - y, px - x) - h + math.pi / n, 2 * math.pi)
    idx = np.minimum((rel / (2 * math.pi / n)).astype(int), n - 1)
    out = np.full(n, cap)
    np.minimum.at(out, idx, d)
    return out


def reference_cast(segments: np.ndarray, x: float, y: float, angle: float, cap: float) -> float:
    """One ray, one wall at a time, in plain Python (slow and obvious)."""
    ux, uy = math.cos(angle), math.sin(angle)
    best = cap
    for ax, ay, bx, by in segments.tolist():
        dx, dy = bx - ax, by - ay
        denom = ux * dy - uy * dx
        if denom == 0.0:  # parallel (a wall a denormal off parallel still meets the ray)
            continue
        wx, wy = ax - x, ay - y
        t = (wx * dy - wy * dx) / denom
        s = (wx * uy - wy * ux) / denom
        if t > 0 and -1e-9 <= s <= 1 + 1e-9:
            best = min(best, t)
    return best


def test_a_wall_that_touches_the_ray_at_its_end_is_hit_there():
    """A wall from (1, 0) up to (0.5, 2.2e-308), a denormal off the ray along +x: the ray meets
    it at its end point, 1 m out (Hypothesis found the reference missing it as 'parallel')."""
    segs = np.array([[1.0, 0.0, 0.5, 2.2e-308]])
    assert Walls(segs).cast(0.0, 0.0, np.array([0.0]), 5.0)[0] == pytest.approx(1.0)
    assert reference_cast(segs, 0.0, 0.0, 0.0, 5.0) == pytest.approx(1.0)


@settings(max_examples=40, deadline=None)
@given(x=st.floats(-1.4, 5.5), y=st.floats(-3.9, 2.4), h=st.floats(-math.pi, math.pi))
def test_ray_cast_matches_a_plain_python_reference(walls, x, y, h):
    assume(walls.point_clearance(x, y) > 1e-6)  # a ray from a point on a wall is degenerate
    angles = h + np.radians(7.5 * np.arange(48))
    fast = walls.cast(x, y, angles, 5.26)
    slow = [reference_cast(walls.segments, x, y, a, 5.26) for a in angles]
    np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-12)


def test_ray_cast_unit_square_by_hand():
    d = ray_cast(SQUARE, (0.25, 0.5), np.array([0.0, math.pi / 2, math.pi, -math.pi / 2]), 9.0)
    np.testing.assert_allclose(d, [0.75, 0.5, 0.25, 0.5])
    # the diagonal to the corner (1, 1) from (0.5, 0.5): sqrt(0.5), through the shared vertex
    d = ray_cast(SQUARE, (0.5, 0.5), np.array([math.pi / 4]), 9.0)
    np.testing.assert_allclose(d, [math.sqrt(0.5)])


def test_ray_cast_is_capped():
    assert ray_cast(SQUARE, (0.5, 0.5), np.array([0.0]), 0.2)[0] == pytest.approx(0.2)


def test_ray_cast_hailu_world_by_hand(walls):
    # from the start (0, 0): x = 3.5 ahead (the upper door post corner), x = -1.5 behind,
    # y = +-2.5 left and right; at 45 deg the top wall at (2.5, 2.5)
    ang = np.radians([0, 90, 180, 270, 45, 135])
    d = walls.cast(0.0, 0.0, ang, 10.0)
    np.testing.assert_allclose(d, [3.5, 2.5, 1.5, 2.5, 2.5 * math.sqrt(2), 1.5 * math.sqrt(2)])
    # through the door along y = -0.5 to the far corridor wall x = 5.55
    assert walls.cast(2.0, -0.5, np.array([0.0]), 10.0)[0] == pytest.approx(3.55)


def test_clearance_by_hand(walls):
    pts = np.array([[0.0, 0.0], [3.0, -0.5], [4.65, -2.0], [3.625, -0.5]])
    # (3.0, -0.5) faces the door gap, so its nearest walls are the door posts' corners
    # (3.5, -1) and (3.5, 0), sqrt(0.5^2 + 0.5^2) away; (3.625, -0.5) is mid-door
    np.testing.assert_allclose(clearance(walls, pts), [1.5, math.sqrt(0.5), 0.9, 0.5])
    assert walls.point_clearance(3.625, -0.5) == pytest.approx(0.5)
    assert clearance(walls, pts.reshape(2, 2, 2)).shape == (2, 2)


def test_sector_distances_by_hand(walls):
    # 0.36 m below the top wall y = 2.5: sector k (axis k*15 deg) sees the wall at its edge
    # nearest to 90 deg, at 0.36 / sin(edge); sector 6 (90 deg) sees the foot at 0.36
    x, y = 0.0, 2.5 - 0.36
    d = sector_distances(walls, (x, y, 0.0), 24, 0.76)
    assert d[6] == pytest.approx(0.36)
    for k, edge in ((5, 82.5), (4, 67.5), (3, 52.5), (7, 97.5), (8, 112.5)):
        assert d[k] == pytest.approx(min(0.36 / math.sin(math.radians(edge)), 0.76)), k
    assert d[2] == pytest.approx(0.36 / math.sin(math.radians(37.5)))
    assert d[1] == pytest.approx(0.76)  # 0.36 / sin(22.5 deg) = 0.94 is beyond the cap
    assert d.min() == pytest.approx(walls.point_clearance(x, y))


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-1.5, 5.55),
    y=st.floats(-4.0, 2.5),
    h=st.floats(-math.pi, math.pi),
)
def test_sectors_match_brute_force_and_tile_the_ring(walls, x, y, h):
    world = load_map("hailu2001")
    # (the sampled reference needs a sector's chord of wall to be much wider than its 1 mm
    # sample spacing, so stay 5 cm off the walls; the robot's centre is always 26 cm off)
    assume(world.in_free_area(x, y) and walls.point_clearance(x, y) > 0.05)
    fast = walls.sector_distances(x, y, h, 24, 0.76)
    slow = brute_sectors(walls.segments, x, y, h, 24, 0.76)
    assert np.all(fast <= slow + 1e-9)  # exact minimum <= any sampled point
    assert np.all(slow - fast < 2e-3)  # and the sampling comes close to it
    assert fast.min() == pytest.approx(min(walls.point_clearance(x, y), 0.76))


@settings(max_examples=40, deadline=None)
@given(x=st.floats(-1.4, 5.5), y=st.floats(-3.9, 2.4), h=st.floats(-math.pi, math.pi))
def test_scan_agrees_with_the_separate_queries(walls, x, y, h):
    offsets = np.radians(15.0 * np.arange(24))
    rays, sectors, clear = walls.scan(x, y, h, offsets, 24, 5.26, 0.76)
    np.testing.assert_allclose(rays, walls.cast(x, y, h + offsets, 5.26))
    assert clear == pytest.approx(walls.point_clearance(x, y))
    if sectors is None:
        assert clear >= 0.76
    else:
        np.testing.assert_allclose(sectors, walls.sector_distances(x, y, h, 24, 0.76))


def test_swept_disc_contact_by_hand():
    r = 0.1
    # moving parallel to the bottom wall at height 0.15 (> r): no contact
    assert not swept_disc_contact(SQUARE, (0.3, 0.15), (0.7, 0.15), r)
    # ending 0.05 from the right wall: contact
    assert swept_disc_contact(SQUARE, (0.5, 0.5), (0.95, 0.5), r)
    # passing 0.08 from a thin wall's end point, with both motion ends far away: contact
    thin = np.array([[0.0, 0.0, 0.0, 1.0]])
    assert swept_disc_contact(thin, (-0.5, 1.08), (0.5, 1.08), r)
    assert not swept_disc_contact(thin, (-0.5, 1.12), (0.5, 1.12), r)
    # jumping clean through a thin wall (motion longer than 2r): contact
    assert swept_disc_contact(thin, (-0.5, 0.5), (0.5, 0.5), r)


def test_walls_reject_degenerate_input():
    with pytest.raises(ValueError, match="zero length"):
        Walls(np.array([[0.0, 0.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match="finite"):
        Walls(np.array([[0.0, 0.0, np.nan, 1.0]]))
    with pytest.raises(ValueError, match="at least one"):
        Walls(np.zeros((0, 4)))


@settings(max_examples=40, deadline=None)
@given(
    coords=st.lists(st.floats(-1.0, 1.0), min_size=12, max_size=12),
    h=st.floats(-math.pi, math.pi),
)
def test_sectors_and_rays_on_random_oblique_walls(coords, h):
    segs = np.array(coords).reshape(3, 4)
    assume(np.all(np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) > 1e-3))
    walls = Walls(segs)
    assume(walls.point_clearance(0.0, 0.0) > 0.05)
    fast = walls.sector_distances(0.0, 0.0, h, 24, 5.0)
    slow = brute_sectors(segs, 0.0, 0.0, h, 24, 5.0)
    assert np.all(fast <= slow + 1e-9)
    assert np.all(slow - fast < 2e-3)
    assert fast.min() == pytest.approx(min(walls.point_clearance(0.0, 0.0), 5.0))
    angles = h + np.radians(15.0 * np.arange(24))
    expected = [reference_cast(segs, 0.0, 0.0, a, 5.0) for a in angles]
    np.testing.assert_allclose(walls.cast(0.0, 0.0, angles, 5.0), expected, rtol=1e-9)
