"""The shipped worlds: each loads, the reflex alone can drive a trial on it, and the planner
finds its optimum (pinned, so a change to a map or to the planner shows up here)."""

from __future__ import annotations

import numpy as np
import pytest

from symrl.drive import drive
from symrl.knowledge.planner import shortest_path
from symrl.world import load_map
from symrl.world.worldmap import builtin_maps

# map -> (shortest path in metres at the default clearance 0.316 m, actions of 0.20 m)
OPTIMA = {
    "hailu2001": (4.913, 25),
    "hailu2001_mirror": (4.913, 25),
    "two_doors": (7.121, 36),
    "two_door_room": (5.200, 27),
    "office": (13.005, 66),
    "l_corridor": (10.760, 54),
    "maze": (10.681, 54),
    "dead_end": (5.175, 26),
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


def _crossings(points: np.ndarray, x: float) -> list[float]:
    """The y of every crossing of the vertical line at ``x`` by a polyline."""
    a, b = points[:-1], points[1:]
    return [
        float(a[i, 1] + (x - a[i, 0]) * (b[i, 1] - a[i, 1]) / (b[i, 0] - a[i, 0]))
        for i in np.flatnonzero((a[:, 0] - x) * (b[:, 0] - x) < 0)
    ]


def test_two_door_room_the_reflex_takes_the_upper_door_the_optimum_the_lower():
    world = load_map("two_door_room")
    # the goal's bearing from the start crosses the dividing wall (x 3.5..3.75) in the upper door
    s, g = world.start, world.goal
    y_wall = s.y + (3.625 - s.x) * (g.y - s.y) / (g.x - s.x)
    assert -0.5 < y_wall < 0.5
    # the optimum goes through the lower door (y -2.25..-1.25) ...
    (y,) = _crossings(shortest_path(world).points, 3.625)
    assert -2.25 < y < -1.25
    # ... the reflex alone through the upper door, into the west lane, down it and stuck at
    # the partition's end (the mirror-symmetric reflex gets 5 cm past it, at x 4.66, y -1.81)
    trial = drive(map=world, noise=False)
    path = np.asarray(trial["path"])
    assert all(-0.5 < y < 0.5 for y in _crossings(path, 3.625))
    assert _crossings(path, 3.625)
    assert 3.75 < path[-1, 0] < 4.75 and not trial["reached_goal"]
    # the regions name the poses of both routes
    names = {
        (x, y): world.regions.region_of(x, y)
        for x, y in [(1.0, 0.0), (3.6, 0.0), (3.6, -1.75), (4.2, 0.5), (5.1, -0.5), (4.2, -2.0)]
    }
    assert names == {
        (1.0, 0.0): "room",
        (3.6, 0.0): "upper_door",
        (3.6, -1.75): "lower_door",
        (4.2, 0.5): "corridor",
        (5.1, -0.5): "corridor",
        (4.2, -2.0): "corridor",
    }


def test_dead_end_the_reflex_enters_the_pocket_the_optimum_goes_round():
    world = load_map("dead_end")
    s, g = world.start, world.goal
    assert s.y == g.y and 1.5 < s.y < 3.0  # the goal's bearing runs into the pocket's mouth
    plan = shortest_path(world)
    inside = (plan.points[:, 0] > 2.5) & (plan.points[:, 0] < 4.5)
    ys = plan.points[inside, 1]
    assert bool(((ys < 1.5) | (ys > 3.0)).all())  # round the pocket, never in it
    path = np.asarray(drive(map=world, noise=False)["path"])
    end = path[-1]
    assert 2.5 < end[0] < 4.5 and 1.5 < end[1] < 3.0  # the reflex ends inside the pocket
    assert world.regions.region_of(*end) == "pocket"
    names = {
        p: world.regions.region_of(*p)
        for p in [(0.8, 2.25), (3.5, 2.25), (3.5, 3.7), (3.5, 0.7), (5.6, 2.25), (2.0, 4.0)]
    }
    assert names == {
        (0.8, 2.25): "west",
        (3.5, 2.25): "pocket",
        (3.5, 3.7): "north",
        (3.5, 0.7): "south",
        (5.6, 2.25): "east",
        (2.0, 4.0): "west",
    }
