"""The shipped worlds: each loads, the reflex alone can drive a trial on it, and the planner
finds its optimum (pinned, so a change to a map or to the planner shows up here)."""

from __future__ import annotations

import numpy as np
import pytest

from symrl.drive import drive
from symrl.studies.planner import shortest_path
from symrl.world import load_map
from symrl.world.worldmap import builtin_maps

# map -> (shortest path in metres at the default clearance 0.316 m, actions of 0.20 m)
OPTIMA = {
    "hailu2001": (4.913, 25),
    "hailu2001_mirror": (4.913, 25),
    "two_doors": (7.121, 36),
    "office": (13.005, 66),
    "l_corridor": (10.760, 54),
    "maze": (10.681, 54),
}


def test_the_gallery_is_shipped():
    assert set(OPTIMA) <= set(builtin_maps())


@pytest.mark.parametrize("name", sorted(OPTIMA))
def test_map_loads_and_the_planner_finds_its_optimum(name):
    world = load_map(name)
    assert world.name == name
    plan = shortest_path(world)
    length, actions = OPTIMA[name]
    assert plan.length == pytest.approx(length, abs=2e-3)
    assert plan.actions == actions
    assert bool(world.in_free_area(plan.points[:, 0], plan.points[:, 1]).all())


@pytest.mark.parametrize("name", sorted(OPTIMA))
def test_the_reflex_alone_drives_a_trial(name):
    world = load_map(name)
    result = drive(map=world, noise=False, max_actions=30)
    assert 0 < result["steps"] <= 30
    path = np.asarray(result["path"])
    assert path[0] == pytest.approx((world.start.x, world.start.y))
    assert bool(world.in_free_area(path[:, 0], path[:, 1]).all())


def test_mirror_is_the_paper_world_upside_down():
    paper, mirror = load_map("hailu2001"), load_map("hailu2001_mirror")
    flip = np.array([1.0, -1.0])
    assert {tuple(p) for p in paper.boundary * flip} == {tuple(p) for p in mirror.boundary}
    assert (mirror.goal.x, mirror.goal.y) == (paper.goal.x, -paper.goal.y)
    for x, y in [(0.0, 0.0), (1.0, -2.0), (3.6, -0.5), (4.5, 0.0)]:
        assert paper.regions.region_of(x, y) == mirror.regions.region_of(x, -y)


def test_two_doors_shorter_route_is_off_the_goal_bearing():
    world = load_map("two_doors")
    plan = shortest_path(world)
    # the goal is due east of the start, level with the upper door (y 4..5) ...
    assert world.start.y == world.goal.y and 4.0 < world.goal.y < 5.0
    # ... but the optimum crosses the dividing wall (x 5..5.25) through the lower door (y 1..2)
    a, b = plan.points[:-1], plan.points[1:]
    across = np.flatnonzero((a[:, 0] < 5.125) & (b[:, 0] >= 5.125))
    assert len(across) == 1
    i = int(across[0])
    y = a[i, 1] + (5.125 - a[i, 0]) * (b[i, 1] - a[i, 1]) / (b[i, 0] - a[i, 0])
    assert 1.0 < y < 2.0
