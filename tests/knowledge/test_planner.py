"""The planner against lengths computed by hand on tiny maps, and on the paper's world."""

from __future__ import annotations

import math

import numpy as np
import pytest

from symrl.knowledge.planner import shortest_path
from symrl.world import load_map

REGIONS = {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]}


def _map(boundary, start, goal, radius):
    return load_map(
        {
            "name": "test",
            "boundary": boundary,
            "start": {"x": start[0], "y": start[1], "heading": 0.0},
            "goal": {"x": goal[0], "y": goal[1], "radius": radius},
            "regions": REGIONS,
        }
    )


def test_empty_box_is_the_straight_line_minus_the_goal_radius():
    world = _map([[0, 0], [10, 0], [10, 10], [0, 10]], (1, 1), (9, 1), 0.4)
    plan = shortest_path(world, clearance=0.316, step=0.2)
    assert plan.length == pytest.approx(8.0 - 0.4, abs=1e-9)
    assert plan.actions == 38  # 7.6 / 0.2


def test_l_corridor_wraps_the_inner_corner_on_a_circle():
    # arms x in [0, 4] x y in [0, 1] and x in [3, 4] x y in [0, 4]; inner corner (3, 1)
    world = _map([[0, 0], [4, 0], [4, 4], [3, 4], [3, 1], [0, 1]], (0.5, 0.5), (3.5, 3.5), 0.1)
    r = 0.3
    d = math.sqrt(2.5**2 + 0.5**2)  # start and goal are both this far from the corner
    tangent = math.sqrt(d * d - r * r)
    off = math.acos(r / d)
    # directions corner->start (191.31 deg) and corner->goal (78.69 deg) are 247.38 deg apart
    # the free way round; each tangent point eats `off` of it
    sweep = 2 * math.pi - math.acos((-2.5 * 0.5 - 0.5 * 2.5) / d**2) - 2 * off
    expected = 2 * tangent + r * sweep - 0.1
    plan = shortest_path(world, clearance=r, step=0.2)
    assert plan.length == pytest.approx(expected, abs=1e-6)
    assert plan.actions == math.ceil(expected / 0.2)
    # every point of the path keeps the clearance (up to the 5 mm chords of the arc)
    from symrl.world.geometry import Walls

    assert Walls(world.segments).clearance(plan.points).min() >= r - 1e-4


def test_goal_centre_too_close_to_a_wall_ends_where_the_rim_meets_the_grown_wall():
    # goal centre 0.2 m from the bottom wall, clearance 0.3: the first reachable rim point of the
    # goal (radius 0.4) straight ahead lies on y = 0.3, at x = 5 - sqrt(0.4^2 - 0.1^2)
    world = _map([[0, 0], [10, 0], [10, 10], [0, 10]], (1, 0.3), (5, 0.2), 0.4)
    plan = shortest_path(world, clearance=0.3, step=0.2)
    assert plan.length == pytest.approx(4.0 - math.sqrt(0.16 - 0.01), abs=1e-6)


def test_bad_start_raises_a_clear_error():
    world = _map([[0, 0], [10, 0], [10, 10], [0, 10]], (1, 1), (9, 1), 0.4)
    with pytest.raises(ValueError, match="closer than"):
        shortest_path(world, start=(0.1, 5.0), clearance=0.3)


def test_plans_on_one_map_reuse_its_checks_and_give_the_same_plan_as_a_fresh_map():
    """The checker of a map remembers its answers: a second plan from another start asks
    mostly the same questions again, and its plan is the one a fresh copy of the map gives."""
    from symrl.knowledge import planner
    from symrl.knowledge.path_checks import path_checker

    world = load_map("hailu2001")
    shortest_path(world)
    radius, ir_distance, _ = planner.robot_clearances()
    chk = path_checker(world, float(radius + ir_distance))
    asked = len(chk.points_cache)
    second = shortest_path(world, start=(1.0, 1.5))
    new = len(chk.points_cache) - asked
    assert 0 < new < asked / 2  # the start's own tangents only: the rest is remembered
    fresh = shortest_path(load_map("hailu2001"), start=(1.0, 1.5))
    assert second.length == fresh.length
    np.testing.assert_array_equal(second.points, fresh.points)
    assert path_checker(load_map("hailu2001"), chk.r) is not chk  # a map object of its own
