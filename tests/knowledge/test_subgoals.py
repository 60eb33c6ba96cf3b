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


def test_follow_up_points_are_gone():
    assert not hasattr(SubgoalConfig(), "through")
    assert not hasattr(build_subgoals(load_map("hailu2001")), "then_point")


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="resolution"):
        SubgoalConfig(resolution=0)
    with pytest.raises(ValueError, match="along"):
        SubgoalConfig(along=())


def test_min_clearance_drops_points_near_the_posts(world):
    table = build_subgoals(world, SubgoalConfig(min_clearance=0.45))
    room = table.region_names.index("room")
    assert "l2@+0.8/0.0" not in table.labels[room]  # (3.5, -0.69): 0.31 m from the post
    assert "l2@+0.0/0.0" in table.labels[room]  # the door centre: 0.5 m


# The tables on the paper's map, as built before sub-goals came from the region graph: the
# learner's results depend on them, so they must not move by a bit.
D, P, C, L = 3.9000000953674316, 4.150000095367432, -0.6919999718666077, (4.0, -2.0)
PAPER_TABLE = {
    "labels": [
        ["goal", "l2@+0.0/0.4", "l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l2@+0.0/0.4", "l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l2@+0.0/0.4", "l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l3@+0.0/0.4", "l3@+0.8/0.4"],
    ],
    "points": [
        [L, (D, -0.5), (P, -0.5), (P, C)],
        [L, (D, -0.5), (P, -0.5), (P, C)],
        [L, (D, -0.5), (P, -0.5), (P, C)],
        [L, (P, -0.5), (P, C), (0.0, 0.0)],
    ],
}
DEFAULT_TABLE = {
    "labels": [
        ["goal", "l2@+0.0/0.0", "l2@+0.0/0.4", "l2@+0.8/0.0", "l2@+0.8/0.4"]
        + ["l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l2@+0.0/0.0", "l2@+0.0/0.4", "l2@+0.8/0.0", "l2@+0.8/0.4"]
        + ["l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l2@+0.0/0.4", "l2@+0.8/0.4", "l3@+0.0/0.4", "l3@+0.8/0.4"],
        ["goal", "l3@+0.0/0.4", "l3@+0.8/0.4"],
    ],
    "points": [
        [L, (3.5, -0.5), (D, -0.5), (3.5, C), (D, C), (P, -0.5), (P, C)],
        [L, (3.5, -0.5), (D, -0.5), (3.5, C), (D, C), (P, -0.5), (P, C)],
        [L, (D, -0.5), (D, C), (P, -0.5), (P, C), (0.0, 0.0), (0.0, 0.0)],
        [L, (P, -0.5), (P, C)] + [(0.0, 0.0)] * 4,
    ],
}


@pytest.mark.parametrize(
    ("config", "expected"),
    [
        (SubgoalConfig(past=True, beyond=(0.4,), min_clearance=0.45), PAPER_TABLE),
        (SubgoalConfig(), DEFAULT_TABLE),
    ],
    ids=["paper_map", "default"],
)
def test_paper_map_tables_are_pinned(world, config, expected):
    table = build_subgoals(world, config)
    assert table.region_names == ("room", "concave", "door", "corridor")
    assert table.labels == expected["labels"]
    assert torch.equal(table.points, torch.tensor(expected["points"], dtype=torch.float32))
    counts = [len(labels) for labels in expected["labels"]]
    assert table.valid.tolist() == [[k < n for k in range(table.valid.shape[1])] for n in counts]


def _region_options(table, region: str) -> list[str]:
    return table.labels[table.region_names.index(region)]


def test_a_door_closed_by_a_thin_wall_is_no_passage():
    doc = {
        "name": "closed",
        "boundary": [[0, 0], [8, 0], [8, 4], [0, 4]],
        # a thin wall at x = 4 with two 1 m doors; the upper one is closed by one more segment
        "segments": [
            [[4.0, 0.0], [4.0, 0.5]],
            [[4.0, 1.5], [4.0, 2.5]],
            [[4.0, 2.5], [4.0, 3.5]],
            [[4.0, 3.5], [4.0, 4.0]],
        ],
        "start": {"x": 1, "y": 2},
        "goal": {"x": 7, "y": 2, "radius": 0.4},
        "regions": {
            "names": ["west", "east"],
            "lines": {"wall": {"x": 4.0}},
            "rules": [{"region": "west", "when": ["x < wall"]}, {"region": "east"}],
        },
    }
    world = load_map(doc)
    passages = find_passages(world)
    assert len(passages) == 1  # only the lower door, y in [0.5, 1.5]
    assert passages[0].lo == pytest.approx(0.5, abs=0.02)
    assert passages[0].hi == pytest.approx(1.5, abs=0.02)


def test_a_door_closed_inside_its_region_leaves_no_route():
    # the paper's map with the door region cut across by a thin wall, and a second way round
    # through a gap in the corridor's west wall further north: the door is no longer on a route
    world = load_map(
        {
            "name": "cut",
            "boundary": [[0, 0], [3.5, 0], [3.5, 1], [3.75, 1], [3.75, 0], [6, 0], [6, 4]]
            + [[3.75, 4], [3.75, 3.5], [3.5, 3.5], [3.5, 4], [0, 4]],
            "obstacles": [[[3.5, 2.0], [3.75, 2.0], [3.75, 2.5], [3.5, 2.5]]],
            "segments": [[[3.6, 1.0], [3.6, 2.0]]],
            "start": {"x": 1, "y": 1.5},
            "goal": {"x": 5, "y": 1.5, "radius": 0.4},
            "regions": {
                "names": ["room", "door", "gap", "corridor"],
                "lines": {"w": {"x": 3.5}, "e": {"x": 3.75}, "mid": {"y": 2.25}},
                "rules": [
                    {"region": "room", "when": ["x < w"]},
                    {"region": "corridor", "when": ["x > e"]},
                    {"region": "door", "when": ["y < mid"]},
                    {"region": "gap"},
                ],
            },
        }
    )
    table = build_subgoals(world, SubgoalConfig(past=False))
    room = _region_options(table, "room")
    assert any(label.startswith("w#2@") for label in room)  # the gap (upper crossing of w)
    assert not any(label.startswith("w#1@") for label in room)  # the cut door


def test_options_skip_dead_ends_and_labels_are_unique():
    office = load_map("office")
    table = build_subgoals(office)
    # the west office's routes leave by the west door and enter the east office; the middle
    # door, a dead end for this goal, is never an option; the east door is one from the
    # corridor, which sees it (from the west office it lies behind walls)
    west = _region_options(table, "west_office")
    assert any(label.startswith("hall#1@") for label in west)
    assert not any(label.startswith("hall#2@") for label in west)
    corridor = _region_options(table, "corridor")
    assert any(label.startswith("hall#3@") for label in corridor)
    assert not any(label.startswith("hall#2@") for label in corridor)
    for labels in table.labels:
        assert len(labels) == len(set(labels))


def test_maze_options_avoid_the_dead_end_toward_the_goal():
    maze = load_map("maze")
    passages = find_passages(maze)
    table = build_subgoals(maze, SubgoalConfig(past=False))
    hall = table.region_names.index("west_hall")
    points = [table.point(hall, k) for k in range(1, int(table.counts[hall]))]
    # the way is north then east: no option in the middle lane (the dead end due east of the
    # start, toward the goal's bearing) nor in the south lane
    assert points and not any(1.5 <= x <= 7.5 and y < 4.0 for x, y in points)
    assert any(y > 4.0 and x < 2.0 for x, y in points)
    # the north wall is thin: its crossing opens only at the 1.5 m gap east of x = 8.5
    north = [p for p in passages if p.line == "north"]
    assert len(north) == 1 and north[0].lo == pytest.approx(8.5, abs=0.02)


def test_two_doors_both_routes_are_options():
    table = build_subgoals(load_map("two_doors"))
    room = _region_options(table, "room")
    assert any(label.startswith("wall_w#1@") for label in room)
    assert any(label.startswith("wall_w#2@") for label in room)
    assert len(room) == len(set(room))


def _labels_of(table, region: str) -> list[str]:
    return table.labels[table.region_names.index(region)]


def test_points_no_place_of_the_region_sees_are_not_offered():
    """From the west office the east office's door lies behind two walls: the reflex would
    jam against the wall steering at it. The pocket of dead_end sees out of its mouth only."""
    config = SubgoalConfig(beyond=(0.4,), min_clearance=0.45)
    office = build_subgoals(load_map("office"), config)
    blind = build_subgoals(
        load_map("office"), SubgoalConfig(beyond=(0.4,), min_clearance=0.45, visible=False)
    )
    assert any(lb.startswith("offices#3") for lb in _labels_of(blind, "west_office"))
    assert not any(lb.startswith("offices#3") for lb in _labels_of(office, "west_office"))
    assert any(lb.startswith("offices#1") for lb in _labels_of(office, "west_office"))
    assert any(lb.startswith("offices#3") for lb in _labels_of(office, "east_door"))
    pocket = _labels_of(build_subgoals(load_map("dead_end"), config), "pocket")
    assert pocket == ["goal", "mouth#2@+0.0/0.4", "mouth#2@+0.8/0.4"]


def test_every_point_of_the_paper_map_is_seen_from_its_region(world):
    config = SubgoalConfig(beyond=(0.4,), min_clearance=0.45)
    seen = build_subgoals(world, config)
    blind = build_subgoals(world, SubgoalConfig(beyond=(0.4,), min_clearance=0.45, visible=False))
    assert seen.labels == blind.labels
    assert torch.equal(seen.points, blind.points)
