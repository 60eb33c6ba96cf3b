"""SubgoalOptions on a hand-made table: the choice at a region's first entry, the averaging
(or best) critic, epsilon, reaching a sub-goal, and independence of the robots of a batch."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import OptionsConfig, load_config
from symrl.learner.options import SubgoalOptions, _route_lengths
from symrl.world.worldmap import load_map

WORLD = load_map("hailu2001")  # goal (4, -2)
GOAL = (4.0, -2.0)


def paper_map(*overrides: str):
    """The map-rung recipe's config with ``overrides``."""
    return load_config("paper_map", list(overrides))


def _table() -> SubgoalTable:
    """Two regions: region 0 has the goal and two sub-goals, region 1 only the goal."""
    points = torch.tensor(
        [[[4.0, -2.0], [3.5, -0.5], [3.9, -0.5]], [[4.0, -2.0], [0.0, 0.0], [0.0, 0.0]]]
    )
    valid = torch.tensor([[True, True, True], [True, False, False]])
    return SubgoalTable(("a", "b"), points, valid, [["goal", "s1", "s2"], ["goal"]])


def _options(batch: int = 1, seeds=None, **cfg) -> SubgoalOptions:
    config = OptionsConfig(enabled=True, **cfg)
    return SubgoalOptions(WORLD, batch, config, seeds or list(range(batch)), table=_table())


def _odometry(*poses) -> torch.Tensor:
    return torch.tensor(poses, dtype=torch.float32)


def _learn(opt: SubgoalOptions, rows: torch.Tensor, returns: torch.Tensor) -> None:
    """The update's critic step at the end of the trials of ``rows`` (as ``TeseoLoss``)."""
    choice, fallen = opt.trial_choices(rows.numpy())
    opt.critic.learn(rows.numpy(), choice, returns.numpy(), fallen)


def _trial(opt: SubgoalOptions, returns: dict[int, float], row: int = 0) -> int:
    """One trial of robot 0 in region 0 then region 1; region 0's return-to-go depends on
    the option chosen there."""
    rows = torch.tensor([row])
    opt.begin_trial(rows)
    _, option, entered, *_ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=False)
    assert bool(entered[0])
    chosen = int(option[0])
    opt.steer(torch.tensor([1]), _odometry((3.8, -0.5, 0.0)), greedy=False)
    _learn(opt, rows, torch.tensor([[returns[chosen], -1.0]], dtype=torch.float64))
    return chosen


def test_steer_says_which_robots_take_the_start_turn():
    # robot 0 faces away from s1/the goal (about 170 degrees off), robot 1 faces them
    opt = _options(batch=2, epsilon=0.0, start_turn_deg=90.0)
    region = torch.tensor([0, 0])
    poses = _odometry((0.0, 0.0, 3.0), (0.0, 0.0, 0.0))
    *_, turn = opt.steer(region, poses, greedy=True)
    assert turn.tolist() == [True, False]
    *_, turn = opt.steer(region, poses, greedy=True)  # the trial's second step: no turn
    assert turn.tolist() == [False, False]
    opt.begin_trial(torch.tensor([0]))
    *_, turn = opt.steer(region, poses, greedy=True)
    assert turn.tolist() == [True, False]
    *_, turn = _options(epsilon=0.0).steer(torch.tensor([0]), poses[:1], greedy=True)
    assert turn.tolist() == [False]  # start_turn_deg unset: never


def test_untried_options_first_then_greedy_on_the_mean():
    opt = _options(epsilon=0.0)
    chosen = [_trial(opt, {0: -10.0, 1: -5.0, 2: -7.0}) for _ in range(5)]
    assert chosen[:3] == [0, 1, 2]  # each untried option once, in table order
    assert chosen[3:] == [1, 1]
    assert float(opt.critic.q[0, 0, 1]) == pytest.approx(-5.0) and int(opt.critic.n[0, 0, 1]) == 3
    assert float(opt.critic.q[0, 1, 0]) == pytest.approx(-1.0) and int(opt.critic.n[0, 1, 0]) == 5
    assert opt.greedy(0) == [1, 0]
    assert int(opt.critic.trials[0]) == 5


@pytest.mark.parametrize("critic, winner", [("mean", 2), ("best", 1)])
def test_mean_critic_is_robust_to_a_lucky_trial_best_critic_is_not(critic, winner):
    opt = _options(epsilon=0.0, critic=critic)
    # option 1 has one lucky trial (-2) and then bad ones; option 2 is steadily -5
    outcomes = iter([-9.0, -2.0, -12.0, -12.0, -12.0, -12.0])
    for _ in range(6):
        rows = torch.tensor([0])
        opt.begin_trial(rows)
        _, option, _, _, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=False)
        ret = -5.0 if int(option[0]) == 2 else next(outcomes)
        _learn(opt, rows, torch.tensor([[ret, 0.0]], dtype=torch.float64))
    assert opt.greedy(0)[0] == winner
    if critic == "best":
        assert float(opt.critic.q[0, 0, 1]) == pytest.approx(-2.0)


def test_option_is_kept_for_the_trial_and_reaching_it_aims_at_the_goal():
    opt = _options(epsilon=0.0, reach=0.25)
    opt.critic.n[0, 0] = 1  # everything tried: s1 best
    opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)

    def aim(region: int, x: float, y: float) -> float:
        angle, option, _, _, _ = opt.steer(torch.tensor([region]), _odometry((x, y, 0.0)), False)
        assert int(option[0]) == (1 if region == 0 else 0)
        return float(angle[0])

    assert aim(0, 0.0, 0.0) == pytest.approx(math.atan2(-0.5, 3.5))  # at s1
    assert aim(1, 3.6, -0.5) == pytest.approx(math.atan2(-1.5, 0.4))  # region b: the goal
    assert aim(0, 3.0, 0.5) == pytest.approx(math.atan2(-1.0, 0.5))  # back in a: s1 again
    assert aim(0, 3.4, -0.5) == pytest.approx(math.atan2(-1.5, 0.6))  # within reach: the goal
    assert aim(0, 3.0, -0.5) == pytest.approx(math.atan2(-1.5, 1.0))  # stays on the goal
    assert opt.choice[0].tolist() == [1, 0]


def test_goal_lead_steers_at_the_goal_while_the_subgoal_is_in_line_then_commits():
    # from (0, 0) the goal (4, -2) bears -26.6 degrees and s1 (3.5, -0.5) -8.1: 18.4 apart
    opt = _options(epsilon=0.0, goal_lead_deg=20.0)
    opt.critic.n[0, 0] = 1  # everything tried: s1 best
    opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)

    def aim(region: int, x: float, y: float) -> tuple[float, ...]:
        _, _, _, point, _ = opt.steer(torch.tensor([region]), _odometry((x, y, 0.0)), False)
        return tuple(point[0].tolist())

    assert aim(0, 0.0, 0.0) == GOAL  # s1 within 20 degrees of the goal's bearing: the goal
    assert aim(0, 3.0, 0.5) == GOAL  # 4.8 degrees apart: still the goal
    assert aim(0, 2.0, -1.5) == (3.5, -0.5)  # 47.7 degrees apart: s1 ...
    assert aim(0, 0.0, 0.0) == (3.5, -0.5)  # ... for the rest of the visit
    assert aim(1, 3.6, -0.5) == GOAL  # region b has only the goal
    assert aim(0, 0.0, 0.0) == GOAL  # a new visit of a leads again
    opt.begin_trial(torch.tensor([0]))
    assert aim(0, 2.0, -1.5) == (3.5, -0.5)  # a sub-goal far off the goal's bearing: at once


def test_goal_lead_a_subgoal_reached_while_leading_aims_at_the_goal_for_the_visit():
    opt = _options(epsilon=0.0, goal_lead_deg=20.0)
    opt.critic.n[0, 0] = 1
    opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    _, _, _, point, _ = opt.steer(torch.tensor([0]), _odometry((3.4, -0.5, 0.0)), False)
    assert tuple(point[0].tolist()) == GOAL and int(opt.stage[0]) == 2  # within reach
    _, _, _, point, _ = opt.steer(torch.tensor([0]), _odometry((2.0, -1.5, 0.0)), False)
    assert tuple(point[0].tolist()) == GOAL  # whatever the angle now


def test_goal_lead_is_mirror_symmetric():
    # hailu2001_mirror is the paper's world mirrored about y = 0 (goal (4, 2)): the mirrored
    # table and poses lead and commit at the same steps
    table = _table()
    mirrored = SubgoalTable(table.region_names, table.points.clone(), table.valid, table.labels)
    mirrored.points[..., 1] *= -1
    config = OptionsConfig(enabled=True, epsilon=0.0, goal_lead_deg=20.0)
    stages = []
    for name, tab, sign in (("hailu2001", table, 1.0), ("hailu2001_mirror", mirrored, -1.0)):
        opt = SubgoalOptions(load_map(name), 1, config, [0], table=tab)
        opt.critic.n[0, 0] = 1
        opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
        row = []
        for x, y in ((0.0, 0.0), (3.0, 0.5), (2.0, -1.5)):
            opt.steer(torch.tensor([0]), _odometry((x, sign * y, 0.0)), False)
            row.append(int(opt.stage[0]))
        stages.append(row)
    assert stages[0] == stages[1] == [0, 0, 1]


@pytest.mark.parametrize("lead, expected", [(0.0, (3.5, -0.5)), (15.0, (3.5, -0.5)),
                                            (20.0, GOAL)])  # fmt: skip
def test_goal_lead_angle_decides_the_first_step(lead, expected):
    opt = _options(epsilon=0.0, goal_lead_deg=lead)
    opt.critic.n[0, 0] = 1
    opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    _, _, _, point, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    assert tuple(point[0].tolist()) == expected


def test_angle_is_relative_to_the_heading_and_wrapped():
    opt = _options(epsilon=0.0)
    angle, _, _, _, _ = opt.steer(torch.tensor([1]), _odometry((4.0, 0.0, math.pi / 2)), False)
    assert abs(float(angle[0])) == pytest.approx(math.pi)  # the goal straight behind
    angle, _, _, _, _ = opt.steer(torch.tensor([1]), _odometry((4.0, 0.0, -3.0)), False)
    assert -math.pi <= float(angle[0]) <= math.pi
    assert float(angle[0]) == pytest.approx(-math.pi / 2 + 3.0)


def test_epsilon_decays_and_greedy_after_stops_exploring():
    opt = _options(epsilon=1.0, epsilon_decay=0.5, greedy_after=3, try_untried=False)
    opt.critic.n[0, 0] = 1
    opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    for _ in range(3):
        _trial(opt, {0: -9.0, 1: -1.0, 2: -3.0})
    assert float(opt.critic.epsilon[0]) == pytest.approx(0.125)
    late = [_trial(opt, {0: -9.0, 1: -1.0, 2: -3.0}) for _ in range(10)]
    assert set(late) == {1}


def test_epsilon_explores_and_follows_the_robots_seed():
    def run(seed: int, batch_seeds=None) -> list[int]:
        seeds = batch_seeds or [seed]
        opt = _options(len(seeds), seeds, epsilon=1.0, epsilon_decay=1.0, greedy_after=0,
                       try_untried=False)  # fmt: skip
        row = seeds.index(seed)
        out = []
        for _ in range(30):
            rows = torch.arange(len(seeds))
            opt.begin_trial(rows)
            _, option, _, _, _ = opt.steer(torch.zeros(len(seeds), dtype=torch.long),
                                     _odometry(*[(0.0, 0.0, 0.0)] * len(seeds)), False)  # fmt: skip
            out.append(int(option[row]))
        return out

    assert run(3) == run(3) and set(run(3)) == {0, 1, 2}
    assert run(3) != run(4)
    assert run(3, [9, 3, 4]) == run(3)  # robot k of a batch draws as its seed alone


def test_greedy_choice_draws_nothing_and_is_the_best_tried():
    opt = _options(epsilon=1.0, try_untried=True)
    opt.critic.n[0, 0] = torch.tensor([1, 1, 0])
    opt.critic.q[0, 0] = torch.tensor([-9.0, -3.0, 0.0], dtype=torch.float64)
    state = opt.generators[0].get_state()
    _, option, _, _, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=True)
    assert int(option[0]) == 1  # the untried option 2 is not taken greedily
    assert torch.equal(opt.generators[0].get_state(), state)
    opt.begin_trial(torch.tensor([0]))
    fresh = _options(epsilon=0.0)
    _, option, _, _, _ = fresh.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=True)
    assert int(option[0]) == 0  # nothing tried: the first option


def test_learn_only_touches_the_rows_and_regions_chosen():
    opt = _options(batch=2, epsilon=0.0)
    opt.steer(torch.tensor([0, 1]), _odometry((0.0, 0.0, 0.0), (3.8, -0.5, 0.0)), False)
    _learn(opt, torch.tensor([1]), torch.tensor([[-7.0, -2.0]], dtype=torch.float64))
    assert int(opt.critic.n[0].sum()) == 0 and float(opt.critic.epsilon[0]) == 0.0
    assert opt.critic.n[1].tolist() == [[0, 0, 0], [1, 0, 0]]
    assert float(opt.critic.q[1, 1, 0]) == -2.0 and opt.critic.trials.tolist() == [0, 1]


def test_paper_table_shapes_follow_the_switches():
    from symrl.learner.policy import MixtureOfExpertsPolicy

    def labels(*overrides: str) -> list[list[str]]:
        """The labels of each region's valid options."""
        o = MixtureOfExpertsPolicy(load_config("paper_map", list(overrides))).options
        return [[label for k, label in enumerate(row) if bool(o.valid[r, k])]
                for r, row in enumerate(o.labels)]  # fmt: skip

    names = list(load_map("hailu2001").regions.names)
    room, corridor = names.index("room"), names.index("corridor")
    full = labels("options.subgoal_on_line=true", "options.subgoal_min_clearance=0")
    assert "l2@+0.0/0.0" in full[room] and "l2@+0.8/0.4" in full[room]
    paper = labels()
    assert all(label == "goal" or label.endswith("/0.4") for label in paper[room])
    assert "l2@+0.8/0.4" not in paper[room]  # (3.9, -0.69): 0.34 m from the door post
    assert "l3@+0.8/0.4" in paper[room]  # (4.15, -0.69): 0.51 m
    assert len(paper[corridor]) > 1
    assert labels("options.subgoal_past=false", "options.subgoal_planner=false")[corridor] == [
        "goal"
    ]
    assert paper[corridor][-1] == "path"  # the planner's last turn in the corridor


def test_planner_waypoint_rounds_the_partition_that_no_region_line_marks():
    # two_doors: the corridor's passage points lie west of the thin partition (x 6.0, up to
    # y 2.4); aiming at the goal from there runs up the west lane into its dead end. The
    # planner's last turn in the corridor, pushed 0.45 m out, lies past the partition's end.
    from symrl.knowledge.subgoals import _clearance

    world = load_map("two_doors")
    config = load_config("paper_map", ["options.subgoal_planner=true"]).options
    opt = SubgoalOptions(world, 1, config, [0])
    corridor = opt.region_names.index("corridor")
    path = opt.labels[corridor].index("path")
    x, y = opt.table.point(corridor, path)
    assert x > 6.0 and y < 2.4  # east of the partition, below its end
    assert _clearance(world, (x, y)) == pytest.approx(0.45, abs=1e-6)
    assert bool(opt.valid[corridor, path])
    plain = SubgoalOptions(
        world, 1, load_config("paper_map", ["options.subgoal_planner=false"]).options, [0]
    )
    assert "path" not in plain.labels[corridor]


# the tuning world long_wall: a long thin wall at y = 2.5 between the start (south) and the
# goal (north), two lips hanging from it make a bay right above the start; the short way round
# is east (past x = 7.8), the long one west (past x = 2)
LONG_WALL = {
    "name": "long_wall_test",
    "boundary": [[0.0, 0.0], [9.0, 0.0], [9.0, 5.0], [0.0, 5.0]],
    "obstacles": [],
    "segments": [[[2.0, 2.5], [7.8, 2.5]], [[4.0, 1.5], [4.0, 2.5]], [[6.5, 1.5], [6.5, 2.5]]],
    "start": {"x": 5.5, "y": 0.8, "heading": math.pi / 2},
    "goal": {"x": 5.0, "y": 3.9, "radius": 0.40},
    "regions": {
        "names": ["south", "bay", "north", "west_gap", "east_gap"],
        "lines": {"wall": {"y": 2.5}, "lips": {"y": 1.5}, "bay_w": {"x": 4.0},
                  "bay_e": {"x": 6.5}, "w_end": {"x": 2.0}, "e_end": {"x": 7.8}},
        "rules": [
            {"region": "north", "when": ["y > wall"]},
            {"region": "west_gap", "when": ["x < w_end", "y > lips"]},
            {"region": "east_gap", "when": ["x > e_end", "y > lips"]},
            {"region": "bay", "when": ["x > bay_w", "x < bay_e", "y > lips"]},
            {"region": "south"},
        ],
    },
}  # fmt: skip


_NEITHER = ["options.subgoal_detour=null", "options.subgoal_way_out=false"]


def _neither(*overrides: str) -> list[str]:
    """``_NEITHER`` less the keys ``overrides`` set, then ``overrides`` (each key once)."""
    given = {o.split("=")[0] for o in overrides}
    return [o for o in _NEITHER if o.split("=")[0] not in given] + list(overrides)


def _offered(world, *overrides: str) -> dict[str, list[str]]:
    """The labels of the valid options of each region under ``paper`` without the detour and
    way-out rules, then ``overrides``."""
    config = load_config("paper_map", _neither(*overrides)).options
    opt = SubgoalOptions(world, 1, config, [0])
    return {
        name: [label for k, label in enumerate(opt.labels[r]) if bool(opt.valid[r, k])]
        for r, name in enumerate(opt.region_names)
    }


def test_detour_drops_subgoals_off_the_short_way_and_unseen_from_it():
    world = load_map(LONG_WALL)
    full = _offered(world)
    cut = _offered(world, "options.subgoal_detour=1.0")
    # south (the start's region): the west gap's points are 3 m out of the way; the east gap's,
    # the points past the wall's east end and the planner's turn stay
    assert "lips#1@+0.0/0.4" in full["south"] and "w_end@+0.8/0.4" in full["south"]
    assert cut["south"] == ["goal", "wall#2@+0.0/0.4", "wall#2@+0.8/0.4", "lips#3@+0.0/0.4",
                            "lips#3@+0.8/0.4", "e_end@+0.8/0.4", "path"]
    # north, entered from the east on the short way: the points by the west end are dropped
    assert [x for x in full["north"] if x not in cut["north"]] == ["wall#1@+0.0/0.4",
                                                                    "wall#1@+0.8/0.4"]
    # the west gap is off the planner's path: all its options stay
    assert cut["west_gap"] == full["west_gap"]
    # a huge margin drops only the points no place of the path in the region sees: past the
    # wall's west end, behind the wall and the west lip from the south's part of the path
    wide = _offered(world, "options.subgoal_detour=100")
    assert [x for x in full["south"] if x not in wide["south"]] == ["wall#1@+0.0/0.4",
                                                                    "wall#1@+0.8/0.4"]
    # margin 0: only the points on the planner's own length (here none but its turn)
    assert _offered(world, "options.subgoal_detour=0")["east_gap"] == ["goal", "path"]
    # the table keeps its shape (a checkpoint's critic fits either way)
    shapes = {
        SubgoalOptions(world, 1, load_config("paper_map", _neither(*o)).options, [0]).valid.shape
        for o in ([], ["options.subgoal_detour=1.0"])
    }
    assert len(shapes) == 1


def test_detour_keeps_a_subgoal_the_path_sees_though_its_start_does_not():
    # the tuning world side_pocket: a pocket of thin walls opening west, start low in the
    # west, goal high in the east. West's points by the pocket's north-east corner lie behind
    # the pocket from everywhere on the short way (below it): dropped, whatever the margin.
    # A point behind a wall seen from the start but in sight further along the path is kept
    # (long_wall's points past the wall's east end).
    world = load_map({
        "name": "side_pocket_test",
        "boundary": [[0.0, 0.0], [7.5, 0.0], [7.5, 5.0], [0.0, 5.0]],
        "obstacles": [],
        "segments": [[[2.8, 3.0], [4.8, 3.0]], [[2.8, 1.6], [4.8, 1.6]], [[4.8, 1.6], [4.8, 3.0]]],
        "start": {"x": 0.8, "y": 1.0, "heading": 0.0},
        "goal": {"x": 6.4, "y": 3.2, "radius": 0.40},
        "regions": {
            "names": ["west", "pocket", "north", "south", "east"],
            "lines": {"mouth": {"x": 2.8}, "back": {"x": 4.8}, "top": {"y": 3.0},
                      "bottom": {"y": 1.6}},
            "rules": [
                {"region": "west", "when": ["x < mouth"]},
                {"region": "east", "when": ["x > back"]},
                {"region": "north", "when": ["y > top"]},
                {"region": "south", "when": ["y < bottom"]},
                {"region": "pocket"},
            ],
        },
    })  # fmt: skip
    full = _offered(world)
    cut = _offered(world, "options.subgoal_detour=100")
    assert [x for x in full["west"] if x not in cut["west"]] == ["back#2@+0.0/0.4",
                                                                  "back#2@+0.8/0.4"]
    assert all(cut[name] == full[name] for name in full if name != "west")
    assert "wall#2@+0.0/0.4" in _offered(load_map(LONG_WALL), "options.subgoal_detour=100")[
        "south"]  # behind the wall from the start, in sight from the path's east end


def test_way_out_gives_a_dead_end_region_the_planner_turn_out_of_it():
    from symrl.knowledge.subgoals import _clearance

    world = load_map(LONG_WALL)
    assert _offered(world)["bay"] == ["goal"]  # steering at the goal from the bay: its wall
    out = _offered(world, "options.subgoal_way_out=true")
    assert out["bay"] == ["goal", "out"]
    config = load_config("paper_map", _neither("options.subgoal_way_out=true")).options
    opt = SubgoalOptions(world, 1, config, [0])
    bay = opt.region_names.index("bay")
    x, y = opt.table.point(bay, 1)
    # below the bay, 0.45 m off the east lip's end: the bay's short way out (east, round the
    # lip; the west lip's end is 2.3 m away)
    assert y < 1.5 and math.dist((x, y), (6.5, 1.5)) == pytest.approx(0.45, abs=1e-6)
    assert _clearance(world, (x, y)) == pytest.approx(0.45, abs=1e-6)
    # the goal's region and the regions with sub-goals of their own get no way out
    assert all("out" not in labels for name, labels in out.items() if name != "bay")


def test_detour_and_way_out_leave_the_paper_world_unchanged():
    # hailu2001: every sub-goal is straight ahead of its region's entry and on a short way,
    # and every region has sub-goals, so the table (and the learning) are those of paper
    base = SubgoalOptions(WORLD, 1, load_config("paper_map", _NEITHER).options, [0])
    both = SubgoalOptions(WORLD, 1, load_config(
        "paper_map", ["options.subgoal_detour=1.0", "options.subgoal_way_out=true"]).options, [0])
    assert torch.equal(base.valid, both.valid) and torch.equal(base.points, both.points)
    assert base.labels == both.labels


# a 1.2 m corridor opening east into a room; a thin wall hangs from the room's north wall at
# x = 6.5 down to y = 1.0, and the goal lies behind it; the region line `stub` runs through the
# wall, so the planner's path (straight out of the corridor, round the wall's lower end) turns
# only just past the line, in room_east
CORRIDOR_ROOM = {
    "name": "corridor_room_test",
    "boundary": [[0.0, 0.0], [4.0, 0.0], [4.0, -2.0], [9.0, -2.0], [9.0, 4.0], [4.0, 4.0],
                 [4.0, 1.2], [0.0, 1.2]],
    "obstacles": [],
    "segments": [[[6.5, 4.0], [6.5, 1.0]]],
    "start": {"x": 0.6, "y": 0.6, "heading": 0.0},
    "goal": {"x": 8.0, "y": 3.3, "radius": 0.40},
    "regions": {
        "names": ["corridor", "room_west", "room_east"],
        "lines": {"mouth": {"x": 4.0}, "stub": {"x": 6.5}},
        "rules": [
            {"region": "corridor", "when": ["x < mouth"]},
            {"region": "room_west", "when": ["x < stub"]},
            {"region": "room_east"},
        ],
    },
}  # fmt: skip


def test_a_region_the_path_crosses_straight_with_nothing_ahead_gets_the_next_turn():
    from symrl.knowledge.subgoals import _clearance

    world = load_map(CORRIDOR_ROOM)
    offered = _offered(world)
    # room_west's way out is 3 m of open floor (no passage point): before the rule it offered
    # the goal (behind the wall) and the points just past the corridor's mouth only
    assert offered["room_west"] == ["goal", "mouth@+0.0/0.4", "mouth@+0.8/0.4", "path"]
    config = load_config("paper_map", _NEITHER).options
    opt = SubgoalOptions(world, 1, config, [0])
    west = opt.region_names.index("room_west")
    x, y = opt.table.point(west, opt.labels[west].index("path"))
    # below the wall's lower end, 0.45 m from it: the turn round it
    assert y < 1.0 and math.dist((x, y), (6.5, 1.0)) == pytest.approx(0.45, abs=1e-6)
    assert _clearance(world, (x, y)) == pytest.approx(0.45, abs=1e-6)
    # the corridor has its mouth ahead, and the goal's region needs no turn after it
    assert "path" not in offered["corridor"]
    assert offered["room_east"][-1] == "path"  # its own last turn, as before


def test_a_region_whose_points_ahead_are_all_detours_gets_the_next_turn():
    # the box-and-nook room below with its regions found from the walls: a grid of six
    world = load_map({**BOX_AND_NOOK, "regions": "auto"})
    region = world.regions.region_of(1.0, 1.0)  # the start's, south-west of the box
    with_detour = _offered(world, "options.subgoal_detour=1.0")[region]
    # its region-line points lie on the long way round the box's north side, all detours:
    # what is left ahead is the next turn of the path, round the box's south-east corner
    assert with_detour == ["goal", "path"]
    config = load_config("paper_map").options
    opt = SubgoalOptions(world, 1, config, [0])
    r = opt.region_names.index(region)
    x, y = opt.table.point(r, opt.labels[r].index("path"))
    assert x > 6.0 and y < 3.0 and math.dist((x, y), (6.0, 3.0)) == pytest.approx(0.45, abs=1e-6)
    # without the detour test those points count as ahead, and no next turn is added
    assert "path" not in _offered(world)[region]


def test_regions_with_a_passage_ahead_get_no_next_turn():
    # hailu2001: the path runs straight through the room, whose door points lie ahead
    names = _offered(WORLD)
    assert "path" not in names["room"] and names["corridor"][-1] == "path"


# an 8 m x 3 m hall with a side room on its north wall, entered by a 0.8 m door (x 5.8-6.6) in
# the 0.25 m wall at y = 3: coming from the start along the hall, the way meets the door side-on
SIDE_ROOM = {
    "name": "side_room_test",
    "boundary": [[0.0, 0.0], [8.0, 0.0], [8.0, 3.0], [6.6, 3.0], [6.6, 3.25], [7.0, 3.25],
                 [7.0, 6.0], [5.0, 6.0], [5.0, 3.25], [5.8, 3.25], [5.8, 3.0], [0.0, 3.0]],
    "obstacles": [],
    "segments": [],
    "start": {"x": 0.8, "y": 1.5, "heading": 0.0},
    "goal": {"x": 6.0, "y": 5.2, "radius": 0.40},
    "regions": {
        "names": ["hall", "door", "room"],
        "lines": {"wall": {"y": 3.0}, "inner": {"y": 3.25}},
        "rules": [
            {"region": "hall", "when": ["y < wall"]},
            {"region": "door", "when": ["y < inner"]},
            {"region": "room"},
        ],
    },
}  # fmt: skip


def _approach_options(world, *overrides: str) -> SubgoalOptions:
    config = load_config("paper_map", ["options.subgoal_approach=0.7", *overrides]).options
    return SubgoalOptions(world, 1, config, [0])


def test_a_side_on_door_gets_one_approach_option_that_then_steers_through_it():
    opt = _approach_options(load_map(SIDE_ROOM))
    hall = opt.region_names.index("hall")
    valid = [k for k in range(len(opt.labels[hall])) if bool(opt.valid[hall, k])]
    approach = [k for k in valid if opt.labels[hall][k].endswith("@approach")]
    assert [opt.labels[hall][k] for k in approach] == ["wall@approach"]  # one for both faces
    k = approach[0]
    # 0.7 m before the door's centre (x = 6.2) on its normal, then 0.4 m past the line
    assert opt.table.point(hall, k) == pytest.approx((6.2, 2.3), abs=1e-6)
    assert opt.table.then[hall, k].tolist() == pytest.approx([6.2, 3.4], abs=1e-6)
    # the door is met head-on from its own region: no approach there
    door = opt.region_names.index("door")
    assert not any(label.endswith("@approach") and bool(opt.valid[door, j])
                   for j, label in enumerate(opt.labels[door]))  # fmt: skip
    # steering: at the approach point, then (reached) at the point past the door, not the goal
    opt.choice[0, hall] = k
    region = torch.tensor([hall])
    *_, aim, _ = opt.steer(region, _odometry((3.0, 2.0, 0.0)), greedy=True)
    assert aim[0].tolist() == pytest.approx([6.2, 2.3], abs=1e-6)
    *_, aim, _ = opt.steer(region, _odometry((6.1, 2.2, 1.5)), greedy=True)  # within reach
    assert aim[0].tolist() == pytest.approx([6.2, 3.4], abs=1e-6)
    # any other option goes on to the goal once reached, as without approaches
    other = opt.labels[hall].index("inner@+0.0/0.4")
    opt.choice[0, hall] = other
    opt.stage[0], opt.visit[0] = 0, -1
    *_, aim, _ = opt.steer(region, _odometry((6.2, 3.6, 1.5)), greedy=True)
    assert aim[0].tolist() == pytest.approx([6.0, 5.2], abs=1e-6)


def test_approach_options_leave_a_head_on_world_unchanged_and_the_shape_fixed():
    # hailu2001: the way meets the door 8 and 30 degrees off its normal: no valid approach, so
    # the valid options (and the learning) are those without the rule
    base = SubgoalOptions(WORLD, 1, load_config("paper_map", ["options.subgoal_approach=null"])
                          .options, [0])  # fmt: skip
    both = _approach_options(WORLD)
    for opt in (base, both):
        opt.offered = [[(label, opt.table.point(r, k)) for k, label in enumerate(row)
                        if bool(opt.valid[r, k])] for r, row in enumerate(opt.labels)]  # fmt: skip
    assert base.offered == both.offered
    # the columns depend on the map's passages, not on the route: another start, same shape
    moved = load_map(SIDE_ROOM)
    other = dict(SIDE_ROOM, start={"x": 6.2, "y": 0.6, "heading": math.pi / 2})
    assert (_approach_options(moved).table.points.shape
            == _approach_options(load_map(other)).table.points.shape)  # fmt: skip
    # from below the door the way is head-on: its approach option is not valid
    below = _approach_options(load_map(other))
    hall = below.region_names.index("hall")
    assert not any(label.endswith("@approach") and bool(below.valid[hall, k])
                   for k, label in enumerate(below.labels[hall]))  # fmt: skip


# a 10 m x 8 m room, a 2 m box between the start (south-west) and a nook in the north-east
# corner that two thin walls close on the west and the south; the planner's path rounds the
# box's south-east corner, then the nook's wall end: two corners in the one region `main`
BOX_AND_NOOK = {
    "name": "box_nook_test",
    "boundary": [[0.0, 0.0], [10.0, 0.0], [10.0, 8.0], [0.0, 8.0]],
    "obstacles": [[[4.0, 3.0], [6.0, 3.0], [6.0, 5.0], [4.0, 5.0]]],
    "segments": [[[7.5, 8.0], [7.5, 6.5]], [[7.5, 6.5], [9.0, 6.5]]],
    "start": {"x": 1.0, "y": 1.0, "heading": math.pi / 2},
    "goal": {"x": 9.4, "y": 7.4, "radius": 0.40},
    "regions": {
        "names": ["main", "nook"],
        "lines": {"nx": {"x": 7.5}, "ny": {"y": 6.5}},
        "rules": [{"region": "nook", "when": ["x > nx", "y > ny"]}, {"region": "main"}],
    },
}  # fmt: skip


def test_a_region_whose_path_rounds_two_corners_steers_at_the_first_then_the_last():
    world = load_map(BOX_AND_NOOK)

    def path_option(first: bool) -> tuple[SubgoalOptions, int]:
        config = load_config("paper_map", [f"options.subgoal_planner_first={str(first).lower()}"])
        opt = SubgoalOptions(world, 1, config.options, [0])
        return opt, opt.labels[0].index("path")

    last_only, k = path_option(False)
    x, y = last_only.table.point(0, k)
    assert x > 9.0 and 6.0 < y < 6.5  # below the nook's wall end (9, 6.5)
    assert last_only._then is None  # no option goes on to a point of its own
    both, k = path_option(True)
    # the box's south-east corner (6, 3), pushed 0.45 m out; then the nook's wall end as before
    assert math.dist(both.table.point(0, k), (6.0, 3.0)) == pytest.approx(0.45, abs=1e-6)
    assert both.table.then[0, k].tolist() == pytest.approx([x, y], abs=1e-6)
    # steering: the first turn, the last once the first is reached, the goal once that is
    both.choice[0, 0] = k
    region = torch.tensor([0])
    for pose, aim_at in (((2.0, 1.5, 0.0), both.table.point(0, k)), ((6.2, 2.6, 0.8), (x, y)),
                         ((8.0, 5.0, 0.8), (x, y)), ((x, y - 0.1, 1.5), (9.4, 7.4)),
                         ((9.3, 6.8, 1.5), (9.4, 7.4))):  # fmt: skip
        *_, aim, _ = both.steer(region, _odometry(pose), greedy=True)
        assert aim[0].tolist() == pytest.approx(list(aim_at), abs=1e-5), pose


def test_a_region_past_its_limit_goes_on_by_the_planner_option_and_stalls_the_choice():
    world = load_map(LONG_WALL)
    config = load_config("paper_map", ["options.region_limit=3"]).options
    opt = SubgoalOptions(world, 1, config, [0])
    south = opt.region_names.index("south")
    labels = opt.labels[south]
    goal, path = labels.index("goal"), labels.index("path")
    limit = int(opt._limit[south])  # its share of the planner's path (actions) plus 3
    assert limit > 3
    opt.choice[0, south] = goal
    region, pose = torch.tensor([south]), _odometry((5.5, 0.8, math.pi / 2))
    for _ in range(limit):
        _, option, _, aim, _ = opt.steer(region, pose, greedy=True)
        assert int(option[0]) == goal and aim[0].tolist() == pytest.approx([5.0, 3.9])
    _, option, _, aim, _ = opt.steer(region, pose, greedy=True)  # one action past the limit
    assert int(option[0]) == path
    assert aim[0].tolist() == pytest.approx(list(opt.table.point(south, path)), abs=1e-6)
    # the trial's credit goes to the choice, which is then not chosen again
    returns = torch.full((1, len(opt.region_names)), -50.0, dtype=torch.float64)
    _learn(opt, torch.tensor([0]), returns)
    assert int(opt.critic.n[0, south, goal]) == 1 and bool(opt.critic.stalled[0, south, goal])
    opt.begin_trial(torch.tensor([0]))
    assert not opt._fallen_back.any() and not opt._region_steps.any()
    opt.critic.q[0, south, goal] = 100.0  # even as the best value
    for _ in range(40):  # untried first, then epsilon-greedy: never the stalled option
        assert opt._choose(0, south, greedy=False) != goal
        opt.critic.n[0, south] += 1
    # without a limit nothing stalls and the state dict is that of the paper's options
    plain = SubgoalOptions(world, 1, paper_map("options.region_limit=null").options, [0])
    assert "critic.stalled" not in plain.state_dict() and not plain.critic.stalls


def test_a_regions_limit_is_its_length_of_the_planners_path_not_a_count_of_its_points():
    from symrl.knowledge.planner import shortest_path

    world = load_map("l_corridor")  # the path rounds the inner corner in a few cm of arc
    opt = SubgoalOptions(world, 1, paper_map("options.region_limit=5").options, [0])
    plan = shortest_path(world)
    lengths = _route_lengths(world)
    assert sum(lengths.values()) == pytest.approx(plan.length, rel=1e-5)  # chords of its arcs
    # the corner region: a point every few millimetres on the arc, but under 0.6 m of path
    corner = opt.region_names.index("corner")
    assert lengths["corner"] < 0.6
    assert int(opt._limit[corner]) == 5 + math.ceil(lengths["corner"] / 0.2) <= 8
    for i, name in enumerate(opt.region_names):
        assert int(opt._limit[i]) == 5 + math.ceil(lengths.get(name, 0.0) / 0.2)


def test_a_region_without_a_planner_option_goes_on_by_the_planner_from_where_the_robot_is():
    from symrl.knowledge.subgoals import _clearance

    world = load_map(LONG_WALL)
    opt = SubgoalOptions(world, 1, paper_map("options.region_limit=2").options, [0])
    west = opt.region_names.index("west_gap")
    assert int(opt._planner_option[west]) == -1 and int(opt._limit[west]) == 2  # off the path
    opt.choice[0, west] = opt.labels[west].index("goal")
    region, pose = torch.tensor([west]), _odometry((1.2, 2.2, 0.0))
    for _ in range(2):
        *_, aim, _ = opt.steer(region, pose, greedy=True)
        assert aim[0].tolist() == pytest.approx([5.0, 3.9])  # the goal: under the long wall
    *_, aim, _ = opt.steer(region, pose, greedy=True)
    # past the limit: the planner's first turn from here, round the wall's west end (2, 2.5),
    # pushed 0.45 m out
    x, y = aim[0].tolist()
    assert math.dist((x, y), (2.0, 2.5)) == pytest.approx(0.45, abs=1e-6)
    assert _clearance(world, (x, y)) == pytest.approx(0.45, abs=1e-6)
    _learn(opt, torch.tensor([0]), torch.zeros((1, len(opt.region_names)), dtype=torch.float64))
    assert bool(opt.critic.stalled[0, west, opt.labels[west].index("goal")])


def test_a_region_past_its_limit_on_its_planner_option_goes_on_by_the_planner_from_where_it_is():
    """The fallback would be the option already in force (a robot circling an obstacle it met
    on the far side): the planner's path is planned again from the robot's position."""
    world = load_map(LONG_WALL)
    opt = SubgoalOptions(world, 1, paper_map("options.region_limit=2").options, [0])
    south = opt.region_names.index("south")
    path = int(opt._planner_option[south])
    limit = int(opt._limit[south])
    opt.choice[0, south] = path
    region, pose = torch.tensor([south]), _odometry((3.0, 1.0, 0.0))  # west of the path's turn
    point = list(opt.table.point(south, path))
    for _ in range(limit):
        _, option, _, aim, _ = opt.steer(region, pose, greedy=True)
        assert int(option[0]) == path and aim[0].tolist() == pytest.approx(point, abs=1e-6)
    _, option, _, aim, _ = opt.steer(region, pose, greedy=True)  # one action past the limit
    again = opt._replan(np.array([3.0, 1.0]))  # round the wall's west end from here
    assert math.dist(again, point) > 1.0
    assert int(option[0]) == path and aim[0].tolist() == pytest.approx(again.tolist(), abs=1e-9)
    assert not bool(opt.critic.stalled[0, south, path])  # the planner's option is never stalled


def test_a_region_fallen_back_to_its_planner_option_and_still_in_it_the_slack_later_replans():
    """The planner option's point reached, the goal's bearing from there can lead back into the
    region (long_wall: from the turn below the east lip, the goal lies over the bay): the slack
    after the fallback, the planner's path from where the robot is."""
    world = load_map(LONG_WALL)
    opt = SubgoalOptions(world, 1, paper_map("options.region_limit=3").options, [0])
    south = opt.region_names.index("south")
    goal, path = opt.labels[south].index("goal"), int(opt._planner_option[south])
    limit = int(opt._limit[south])
    opt.choice[0, south] = goal
    region = torch.tensor([south])
    x, y = opt.table.point(south, path)
    pose = _odometry((x, y, math.pi / 2))  # at the planner option's point: it aims at the goal
    for _ in range(limit):
        opt.steer(region, pose, greedy=True)
    for _ in range(3):  # fallen back: the planner option, its point reached, then the goal
        _, option, _, aim, _ = opt.steer(region, pose, greedy=True)
        assert int(option[0]) == path and aim[0].tolist() == pytest.approx([5.0, 3.9])
    _, option, _, aim, _ = opt.steer(region, pose, greedy=True)  # the slack (3) after the limit
    again = opt._replan(np.array([x, y]))
    assert int(option[0]) == path and aim[0].tolist() == pytest.approx(again.tolist(), abs=1e-9)
    assert math.dist(again, (5.0, 3.9)) > 1.0  # the wall's east end, not the goal
