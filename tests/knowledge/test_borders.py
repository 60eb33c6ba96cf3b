"""Sub-goals from the region rules alone: the borders the rules define, the region graph, the
table of options, and the option timeout that stands in for the planner without a map."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.borders import (
    Border,
    border_subgoals,
    goal_region,
    region_borders,
    region_hops,
)
from symrl.knowledge.option_tables import map_options
from symrl.knowledge.route import ROUTE, option_table
from symrl.knowledge.rungs import Knowledge
from symrl.learner.config import load_config
from symrl.learner.options import SubgoalOptions
from symrl.world.worldmap import load_map, parse_map

INF = math.inf


def test_the_paper_worlds_borders_from_its_rules():
    spec = load_map("hailu2001").regions
    assert region_borders(spec) == [
        Border("l1", 1, -1.0, -INF, 3.5, "concave", "room"),
        Border("l1", 1, -1.0, 3.5, 3.75, "concave", "door"),
        Border("l2", 0, 3.5, -1.0, INF, "room", "door"),
        Border("l3", 0, 3.75, -INF, -1.0, "concave", "corridor"),
        Border("l3", 0, 3.75, -1.0, INF, "door", "corridor"),
    ]


def _two_boxes(goal_x: float) -> dict:
    """Two rooms side by side in a hall, written as box rules with strict comparisons on both
    sides (as ``regions: auto`` writes them): the line x = 5 between them matches neither box
    and falls to the default region, the hall south of them."""
    return {
        "name": "two_boxes",
        "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
        "start": {"x": 5.0, "y": 1.0, "heading": 0.0},
        "goal": {"x": goal_x, "y": 6.0, "radius": 0.4},
        "regions": {
            "names": ["hall", "west", "east"],
            "lines": {"mid": {"x": 5.0}, "top": {"y": 4.0}},
            "rules": [
                {"region": "west", "when": ["x < mid", "y > top"]},
                {"region": "east", "when": ["x > mid", "y > top"]},
                {"region": "hall"},
            ],
        },
    }


@pytest.mark.parametrize(
    ("goal_x", "centre", "region"), [(5.0, "hall", "east"), (5.3, "east", "east")]
)
def test_a_goal_on_a_line_belongs_to_the_region_round_it(goal_x, centre, region):
    """A goal whose centre lies on the line between the two rooms is, by the rules' strict
    comparisons, in the hall; the region round it (a micrometre off, diagonally) is a room (on
    a tie, the one north-east of the centre), and that is the region the hops count from. Off
    the line the centre's region stands."""
    world = parse_map(_two_boxes(goal_x))
    assert world.regions.region_of(world.goal.x, world.goal.y) == centre
    assert goal_region(world.regions, world.goal) == region
    hops = region_hops(world.regions, region_borders(world.regions), world.goal)
    assert hops[region] == 0


def test_hops_count_borders_to_the_goals_region():
    world = load_map("hailu2001")
    hops = region_hops(world.regions, region_borders(world.regions), world.goal)
    assert hops == {"corridor": 0, "concave": 1, "door": 1, "room": 2}


def test_the_table_offers_a_point_of_each_border_toward_the_goal():
    """Room: the goal, 0.5 m along l1 from the concave corner's end and 0.4 m past it, and
    0.5 m up l2 from its end and 0.4 m past it (into the door region and beyond); the corridor,
    which holds the goal, only the goal; no region offers a border back up the graph."""
    world = load_map("hailu2001")
    table = border_subgoals(world.regions, world.goal)
    assert table.region_names == ("room", "concave", "door", "corridor")
    assert table.labels == [
        ["goal", "l1>concave", "l2>door"],
        ["goal", "l1>door"],  # the corridor's border point lies within 0.3 m of the goal
        ["goal", "l1>concave", "l3>corridor"],
        ["goal"],
    ]
    assert table.point(0, 1) == pytest.approx((3.0, -1.4))
    assert table.point(0, 2) == pytest.approx((3.9, -0.5))
    assert table.point(1, 1) == pytest.approx((3.625, -0.6))  # a short border: its middle
    assert table.point(2, 2) == pytest.approx((4.15, -0.5))


def test_the_table_reads_only_the_rules():
    """Two worlds with the same rules and goal and other walls give the same table."""
    plain = load_map("hailu2001")
    boxed = plain.with_obstacle([[1.0, 1.0], [2.0, 1.0], [2.0, 1.8], [1.0, 1.8]])
    a, b = (border_subgoals(w.regions, w.goal) for w in (plain, boxed))
    assert a.labels == b.labels and torch.equal(a.points, b.points)


@settings(max_examples=30, deadline=None)
@given(split=st.floats(-1.0, 1.0), goal_y=st.floats(-1.8, 1.8))
def test_every_point_lies_in_the_neighbour_it_leads_to(split, goal_y):
    """Two regions split by one line x = split: the west region's option past the border lies
    in the east region, whatever the goal's height, and the east region (the goal's) offers
    only the goal."""
    world = parse_map(
        {
            "name": "split",
            "boundary": [[-2, -2], [2, -2], [2, 2], [-2, 2]],
            "start": {"x": -1.5, "y": 0.0},
            "goal": {"x": 1.8, "y": goal_y, "radius": 0.1},
            "regions": {
                "names": ["west", "east"],
                "lines": {"m": {"x": split}},
                "rules": [{"region": "west", "when": ["x < m"]}, {"region": "east"}],
            },
        }
    )
    table = border_subgoals(world.regions, world.goal)
    assert table.labels == [["goal", "m>east"], ["goal"]]
    x, y = table.point(0, 1)
    assert x == pytest.approx(split + 0.4) and y == pytest.approx(goal_y, abs=1e-6)
    assert world.regions.region_of(x, y) == "east"


def _odometry(x: float, y: float, heading: float = 0.0) -> torch.Tensor:
    return torch.tensor([[x, y, heading]], dtype=torch.float32)


def test_without_the_map_an_option_timed_out_gives_way_to_the_best_one_left():
    """region_limit actions in a region on one option: the option is given up (stalled, never
    chosen again) and the region steers by the best option left, with a fresh budget."""
    world = load_map("hailu2001")
    config = load_config("paper", ["options.region_limit=3"]).options
    told = Knowledge.told(world, "regions")
    table = border_subgoals(told.regions, told.goal)
    opt = SubgoalOptions(told, 1, config, [0], table)
    room = 0
    opt.choice[0, room] = 0  # the goal: the concave trap
    opt.critic.q[0, room] = torch.tensor([-20.0, -30.0, -7.0], dtype=torch.float64)
    opt.critic.n[0, room] = torch.tensor([1, 1, 1])
    region, pose = torch.tensor([room]), _odometry(3.0, -0.8)
    for _ in range(3):
        _, option, _, _, _ = opt.steer(region, pose, greedy=False)
        assert int(option[0]) == 0
    _, option, _, aim, _ = opt.steer(region, pose, greedy=False)  # one action past the limit
    assert int(option[0]) == 2 and aim[0].tolist() == pytest.approx([3.9, -0.5], abs=1e-6)
    assert opt.critic.stalled[0, room].tolist() == [True, False, False]
    for _ in range(3):  # the new option has the whole budget again
        _, option, _, _, _ = opt.steer(region, pose, greedy=False)
        assert int(option[0]) == 2


def test_below_the_map_nothing_builds_the_route():
    """The route needs the planner: an agent told less than the map gets the same table it
    would without the route, and asking for the route option below the map is an error."""
    world = load_map("hailu2001")
    for rung, source in (("regions", "rules"), ("passages", "passages")):
        told = Knowledge.told(world, rung)
        config = load_config(
            "paper", [f"options.source={source}", f"knowledge={rung}", "crossings.enabled=false"]
        )
        opt = SubgoalOptions(told, 1, config.options, [0])
        assert opt.route is None and all(ROUTE not in row for row in opt.labels)
        refused = f"options.source=map needs knowledge=map .* knowledge={rung}$"
        with pytest.raises(ValueError, match=refused):
            option_table(told, "map")
        walls = f"route option needs knowledge=map .* knowledge={rung}$"
        with pytest.raises(ValueError, match=walls):
            map_options(told)  # the source itself asks for the walls
    mapped = option_table(Knowledge.told(world, "map"), "map")
    doors = option_table(Knowledge.told(world, "passages"), "passages")
    assert mapped.labels == [[ROUTE, *row] for row in doors.labels]
    torch.testing.assert_close(mapped.points[:, 1:], doors.points)


def test_told_the_passages_the_options_are_the_doors():
    """office: the rules make the west office border the middle one (through a wall) and the
    door band along its whole width; the passages say where the doors are and that the offices
    connect only through the corridor."""
    world = load_map("office")
    told = Knowledge.told(world, "passages")
    assert told.world is None and told.passages is not None
    rules = border_subgoals(told.regions, told.goal)
    doors = border_subgoals(told.regions, told.goal, told.passages)
    west = told.regions.names.index("west_office")
    assert "wc>middle_office" in rules.labels[west]
    assert doors.labels[west] == ["goal", "offices>west_door"]
    x, y = doors.point(west, 1)
    assert 1.5 < x < 2.5 and y == pytest.approx(2.05 - 0.4)  # through the west door


def test_the_paper_worlds_table_told_the_map_is_pinned():
    """``paper_map``'s options on the paper's world (docs/reference/map-format.md): the route, the
    goal, and the point 0.4 m past the passage toward the goal's region."""
    table = option_table(Knowledge.told(load_map("hailu2001"), "map"), "map")
    assert table.region_names == ("room", "concave", "door", "corridor")
    assert table.labels == [
        [ROUTE, "goal", "l2>door"],
        [ROUTE, "goal", "l1>room"],
        [ROUTE, "goal", "l3>corridor"],
        [ROUTE, "goal"],
    ]
    assert table.point(0, 2) == pytest.approx((3.9, -0.5))
    assert table.point(1, 2) == pytest.approx((3.0, -0.6))
    assert table.point(2, 2) == pytest.approx((4.15, -0.5))
    assert table.valid.sum(dim=1).tolist() == [3, 3, 3, 2]
