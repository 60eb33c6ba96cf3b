"""Sub-goals are derived from the map's region lines, for the paper's map and for any other."""

from __future__ import annotations

import math

import pytest
import torch

from symrl.knowledge.subgoals import SubgoalConfig, build_subgoals, find_passages
from symrl.world.worldmap import load_map


@pytest.fixture(scope="module")
def world():
    return load_map("hailu2001")


def test_passages_of_the_paper_map_are_the_door_and_the_open_floor(world):
    by_line = {p.line: p for p in find_passages(world)}
    assert set(by_line) == {"l1", "l2", "l3"}
    door_in, door_out, floor = by_line["l2"], by_line["l3"], by_line["l1"]
    assert (door_in.before, door_in.after) == ("room", "door")
    assert (door_out.before, door_out.after) == ("door", "corridor")
    assert door_in.lo == pytest.approx(-1.0, abs=0.02) and door_in.hi == pytest.approx(
        0.0, abs=0.02
    )
    assert door_out.width == pytest.approx(1.0, abs=0.03)
    assert floor.width == pytest.approx(5.0, abs=0.03)  # room/concave: open floor
    assert (floor.before, floor.after) == ("concave", "room")


def test_table_per_region_goal_first_and_door_centres(world):
    table = build_subgoals(world)
    assert table.region_names == ("room", "concave", "door", "corridor")
    assert table.points.shape[:2] == table.valid.shape
    for r in range(len(table.region_names)):
        assert table.labels[r][0] == "goal"
        assert table.point(r, 0) == pytest.approx((4.0, -2.0))
    room = table.region_names.index("room")
    points = [table.point(room, k) for k in range(int(table.counts[room]))]
    # the centre of the door on l2 and a point just past it are room options
    assert any(math.dist(p, (3.5, -0.5)) < 0.02 for p in points)
    assert any(math.dist(p, (3.9, -0.5)) < 0.02 for p in points)
    # shifted toward the goal (below the centre), never closer to the post than the robot radius
    assert any(p[1] < -0.6 for p in points)
    assert all(p[1] <= -0.26 + 1e-6 and p[1] >= -0.74 - 1e-6 for p in points[1:])


def test_corridor_gets_only_points_past_the_door_and_switch_off(world):
    table = build_subgoals(world)
    corridor = table.region_names.index("corridor")
    pts = [table.point(corridor, k) for k in range(int(table.counts[corridor]))]
    assert all(p[0] > 3.75 for p in pts[1:]) and len(pts) > 1
    plain = build_subgoals(world, SubgoalConfig(past=False))
    assert int(plain.counts[corridor]) == 1  # only the goal


def test_points_are_free_and_merged(world):
    table = build_subgoals(world)
    for r in range(len(table.region_names)):
        pts = table.points[r][table.valid[r]]
        assert bool(torch.tensor(world.in_free_area(pts[:, 0].numpy(), pts[:, 1].numpy())).all())
        d = torch.cdist(pts, pts) + torch.eye(len(pts)) * 9
        assert float(d.min()) >= SubgoalConfig().merge - 1e-6


def test_invalid_option_raises(world):
    table = build_subgoals(world)
    corridor = table.region_names.index("corridor")
    with pytest.raises(IndexError):
        table.point(corridor, int(table.counts[corridor]))


def test_custom_map_with_two_doors():
    """A room split by a wall with two doors of different width; only the narrow one is a
    bottleneck under max_width, and the sub-goals sit in its middle."""
    data = {
        "name": "two_doors",
        "boundary": [
            [0, 0],
            [4, 0],
            [4, 1],
            [4.2, 1],
            [4.2, 0],
            [8, 0],
            [8, 4],
            [4.2, 4],
            [4.2, 3.8],
            [4, 3.8],
            [4, 4],
            [0, 4],
        ],  # fmt: skip
        "start": {"x": 1, "y": 2},
        "goal": {"x": 7, "y": 2, "radius": 0.4},
        "regions": {
            "names": ["west", "wall", "east"],
            "lines": {"a": {"x": 4.0}, "b": {"x": 4.2}},
            "rules": [
                {"region": "east", "when": ["x > b"]},
                {"region": "west", "when": ["x < a"]},
                {"region": "wall"},
            ],
        },
    }
    # the dividing wall is open for y in [1, 3.8] (2.8 m): too wide for max_width 2
    world = load_map(data)
    passages = find_passages(world)
    assert {(p.line, p.before, p.after) for p in passages} == {
        ("a", "west", "wall"),
        ("b", "wall", "east"),
    }
    assert build_subgoals(world).counts.tolist() == [1, 1, 1]
    wide = build_subgoals(world, SubgoalConfig(max_width=3.0))
    west = [wide.point(0, k) for k in range(int(wide.counts[0]))]
    assert any(math.dist(p, (4.0, 2.4)) < 0.02 for p in west)  # the opening's centre


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="resolution"):
        SubgoalConfig(resolution=0)
    with pytest.raises(ValueError, match="along"):
        SubgoalConfig(along=())


def test_through_gives_follow_up_points_past_the_line(world):
    plain = build_subgoals(world)
    assert all(
        plain.then_point(r, k) is None
        for r in range(len(plain.region_names))
        for k in range(int(plain.counts[r]))
    )
    table = build_subgoals(world, SubgoalConfig(through=0.4))
    room = table.region_names.index("room")
    k = table.labels[room].index("l2@+0.0/0.0")  # the door centre on l2
    assert table.then_point(room, k) == pytest.approx((3.9, -0.5))
    assert table.then_point(room, 0) is None  # the goal has no follow-up


def test_min_clearance_drops_points_near_the_posts(world):
    table = build_subgoals(world, SubgoalConfig(min_clearance=0.45))
    room = table.region_names.index("room")
    assert "l2@+0.8/0.0" not in table.labels[room]  # (3.5, -0.69): 0.31 m from the post
    assert "l2@+0.0/0.0" in table.labels[room]  # the door centre: 0.5 m
