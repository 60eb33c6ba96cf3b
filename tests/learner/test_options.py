"""SubgoalOptions on a hand-made table: the choice at a region's first entry, the averaging
(or best) critic, epsilon, reaching a sub-goal, and independence of the robots of a batch."""

from __future__ import annotations

import math

import pytest
import torch

from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import OptionsConfig, load_config
from symrl.learner.options import SubgoalOptions
from symrl.world.worldmap import load_map

WORLD = load_map("hailu2001")  # goal (4, -2)
GOAL = (4.0, -2.0)


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


def _trial(opt: SubgoalOptions, returns: dict[int, float], row: int = 0) -> int:
    """One trial of robot 0 in region 0 then region 1; region 0's return-to-go depends on
    the option chosen there."""
    rows = torch.tensor([row])
    opt.begin_trial(rows)
    _, option, entered = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=False)
    assert bool(entered[0])
    chosen = int(option[0])
    opt.steer(torch.tensor([1]), _odometry((3.8, -0.5, 0.0)), greedy=False)
    opt.learn(rows, torch.tensor([[returns[chosen], -1.0]], dtype=torch.float64))
    return chosen


def test_untried_options_first_then_greedy_on_the_mean():
    opt = _options(epsilon=0.0)
    chosen = [_trial(opt, {0: -10.0, 1: -5.0, 2: -7.0}) for _ in range(5)]
    assert chosen[:3] == [0, 1, 2]  # each untried option once, in table order
    assert chosen[3:] == [1, 1]
    assert float(opt.q[0, 0, 1]) == pytest.approx(-5.0) and int(opt.n[0, 0, 1]) == 3
    assert float(opt.q[0, 1, 0]) == pytest.approx(-1.0) and int(opt.n[0, 1, 0]) == 5
    assert opt.greedy(0) == [1, 0]
    assert int(opt.trials[0]) == 5


@pytest.mark.parametrize("critic, winner", [("mean", 2), ("best", 1)])
def test_mean_critic_is_robust_to_a_lucky_trial_best_critic_is_not(critic, winner):
    opt = _options(epsilon=0.0, critic=critic)
    # option 1 has one lucky trial (-2) and then bad ones; option 2 is steadily -5
    outcomes = iter([-9.0, -2.0, -12.0, -12.0, -12.0, -12.0])
    for _ in range(6):
        rows = torch.tensor([0])
        opt.begin_trial(rows)
        _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=False)
        ret = -5.0 if int(option[0]) == 2 else next(outcomes)
        opt.learn(rows, torch.tensor([[ret, 0.0]], dtype=torch.float64))
    assert opt.greedy(0)[0] == winner
    if critic == "best":
        assert float(opt.q[0, 0, 1]) == pytest.approx(-2.0)


def test_option_is_kept_for_the_trial_and_reaching_it_aims_at_the_goal():
    opt = _options(epsilon=0.0, reach=0.25)
    opt.n[0, 0] = opt.tries[0, 0] = 1  # everything tried: s1 best
    opt.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)

    def aim(region: int, x: float, y: float) -> float:
        angle, option, _ = opt.steer(torch.tensor([region]), _odometry((x, y, 0.0)), False)
        assert int(option[0]) == (1 if region == 0 else 0)
        return float(angle[0])

    assert aim(0, 0.0, 0.0) == pytest.approx(math.atan2(-0.5, 3.5))  # at s1
    assert aim(1, 3.6, -0.5) == pytest.approx(math.atan2(-1.5, 0.4))  # region b: the goal
    assert aim(0, 3.0, 0.5) == pytest.approx(math.atan2(-1.0, 0.5))  # back in a: s1 again
    assert aim(0, 3.4, -0.5) == pytest.approx(math.atan2(-1.5, 0.6))  # within reach: the goal
    assert aim(0, 3.0, -0.5) == pytest.approx(math.atan2(-1.5, 1.0))  # stays on the goal
    assert opt.choice[0].tolist() == [1, 0]


def test_angle_is_relative_to_the_heading_and_wrapped():
    opt = _options(epsilon=0.0)
    angle, _, _ = opt.steer(torch.tensor([1]), _odometry((4.0, 0.0, math.pi / 2)), False)
    assert abs(float(angle[0])) == pytest.approx(math.pi)  # the goal straight behind
    angle, _, _ = opt.steer(torch.tensor([1]), _odometry((4.0, 0.0, -3.0)), False)
    assert -math.pi <= float(angle[0]) <= math.pi
    assert float(angle[0]) == pytest.approx(-math.pi / 2 + 3.0)


def test_epsilon_decays_and_greedy_after_stops_exploring():
    opt = _options(epsilon=1.0, epsilon_decay=0.5, greedy_after=3, try_untried=False)
    opt.n[0, 0] = 1
    opt.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    for _ in range(3):
        _trial(opt, {0: -9.0, 1: -1.0, 2: -3.0})
    assert float(opt.epsilon[0]) == pytest.approx(0.125)
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
            _, option, _ = opt.steer(torch.zeros(len(seeds), dtype=torch.long),
                                     _odometry(*[(0.0, 0.0, 0.0)] * len(seeds)), False)  # fmt: skip
            out.append(int(option[row]))
        return out

    assert run(3) == run(3) and set(run(3)) == {0, 1, 2}
    assert run(3) != run(4)
    assert run(3, [9, 3, 4]) == run(3)  # robot k of a batch draws as its seed alone


def test_greedy_choice_draws_nothing_and_is_the_best_tried():
    opt = _options(epsilon=1.0, try_untried=True)
    opt.n[0, 0] = torch.tensor([1, 1, 0])
    opt.q[0, 0] = torch.tensor([-9.0, -3.0, 0.0], dtype=torch.float64)
    state = opt.generators[0].get_state()
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=True)
    assert int(option[0]) == 1  # the untried option 2 is not taken greedily
    assert torch.equal(opt.generators[0].get_state(), state)
    opt.begin_trial(torch.tensor([0]))
    fresh = _options(epsilon=0.0)
    _, option, _ = fresh.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=True)
    assert int(option[0]) == 0  # nothing tried: the first option


def test_learn_only_touches_the_rows_and_regions_chosen():
    opt = _options(batch=2, epsilon=0.0)
    opt.steer(torch.tensor([0, 1]), _odometry((0.0, 0.0, 0.0), (3.8, -0.5, 0.0)), False)
    opt.learn(torch.tensor([1]), torch.tensor([[-7.0, -2.0]], dtype=torch.float64))
    assert int(opt.n[0].sum()) == 0 and float(opt.epsilon[0]) == 0.0
    assert opt.n[1].tolist() == [[0, 0, 0], [1, 0, 0]]
    assert float(opt.q[1, 1, 0]) == -2.0 and opt.trials.tolist() == [0, 1]


def test_paper_table_shapes_follow_the_switches():
    from symrl.learner.policy import MixtureOfExpertsPolicy

    def labels(*overrides: str) -> list[list[str]]:
        p = MixtureOfExpertsPolicy(load_config("paper", list(overrides)))
        return p.options.labels

    names = list(load_map("hailu2001").regions.names)
    room, corridor = names.index("room"), names.index("corridor")
    full = labels("options.subgoal_on_line=true", "options.subgoal_min_clearance=0")
    assert "l2@+0.0/0.0" in full[room] and "l2@+0.8/0.4" in full[room]
    paper = labels()
    assert all(label == "goal" or label.endswith("/0.4") for label in paper[room])
    assert "l2@+0.8/0.4" not in paper[room]  # (3.9, -0.69): 0.34 m from the door post
    assert "l3@+0.8/0.4" in paper[room]  # (4.15, -0.69): 0.51 m
    assert len(paper[corridor]) > 1 and labels("options.subgoal_past=false")[corridor] == ["goal"]


# --- the route-choice rules: planner prior, UCB, credit for reaching ---------------------------


def test_planner_prior_tries_the_shorter_door_first_on_the_two_door_room():
    # two_door_room: from the start (1, 0) the goal's bearing points at the upper door, but the
    # optimum (27 actions) goes through the lower door; the prior puts the lower door's points
    # before the upper door's, the goal option first as always.
    world = load_map("two_door_room")
    config = load_config("paper", ["options.prior=planner"]).options
    opt = SubgoalOptions(world, 1, config, [0])
    room = opt.region_names.index("room")
    labels = opt.labels[room]
    upper = labels.index("wall_w#2@+0.0/0.4")  # (3.9, 0.0)
    lower = labels.index("wall_w#1@+0.0/0.4")  # (3.9, -1.75)
    length = opt.route_length[room]
    assert float(length[labels.index("goal")]) == 0.0
    assert float(length[upper]) > float(length[lower]) + 1.0  # 3.16 m against 1.82 m
    options = opt.valid[room].nonzero().flatten()
    order = [labels[int(options[i])] for i in opt._route_order(room, options, torch.tensor(
        [1.0, 0.0], dtype=torch.float64))]  # fmt: skip
    assert order[0] == "goal" and order.index(labels[lower]) < order.index(labels[upper])
    chosen = []
    for _ in range(len(options)):
        opt.begin_trial(torch.tensor([0]))
        _, option, _ = opt.steer(torch.tensor([room]), _odometry((1.0, 0.0, 0.0)), False)
        chosen.append(labels[int(option[0])])
        opt.learn(torch.tensor([0]), torch.zeros(1, len(opt.region_names), dtype=torch.float64))
    assert chosen == order  # the first tries follow the prior


def test_ucb_picks_the_highest_mean_plus_bonus():
    opt = _options(chooser="ucb", ucb_c=2.0, greedy_after=0)
    # region 0: 10 trials; option 1 mean -5 over 8 trials, option 2 mean -6 over 1 trial
    opt.tries[0, 0] = opt.n[0, 0] = torch.tensor([1, 8, 1])
    opt.q[0, 0] = torch.tensor([-20.0, -5.0, -6.0], dtype=torch.float64)
    # scores: -5 + 2 sqrt(ln 10 / 8) = -3.93; -6 + 2 sqrt(ln 10) = -2.97; -20 + 3.03
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    assert int(option[0]) == 2
    opt.begin_trial(torch.tensor([0]))
    opt.tries[0, 0] = opt.n[0, 0] = torch.tensor([1, 8, 8])  # equal evidence: the mean wins
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    assert int(option[0]) == 1
    opt.begin_trial(torch.tensor([0]))
    opt.tries[0, 0] = opt.n[0, 0] = torch.tensor([1, 8, 1])
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), greedy=True)
    assert int(option[0]) == 1  # greedy (evaluation): no bonus


def test_reached_credit_ignores_trials_that_never_got_to_the_sub_goal():
    opt = _options(epsilon=0.0, credit="reached", reach=0.25, credit_radius=0.5)
    rows = torch.tensor([0])
    # trial 1: option 0 (the goal) counts without being reached
    opt.begin_trial(rows)
    opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    opt.learn(rows, torch.tensor([[-10.0, -1.0]], dtype=torch.float64))
    assert opt.n[0, 0].tolist() == [1, 0, 0] and opt.tries[0, 0].tolist() == [1, 0, 0]
    # trial 2: option 1, s1 (3.5, -0.5), never within 0.5 m (closest 0.6 m): tried, no credit
    # (the approach is measured at every step of the trial, in any region)
    opt.begin_trial(rows)
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    assert int(option[0]) == 1
    opt.steer(torch.tensor([0]), _odometry((3.5, 0.1, 0.0)), False)
    assert float(opt.closest[0, 0]) == pytest.approx(0.6)
    opt.steer(torch.tensor([1]), _odometry((3.8, 0.5, 0.0)), False)
    opt.learn(rows, torch.tensor([[-30.0, -1.0]], dtype=torch.float64))
    assert opt.tries[0, 0].tolist() == [1, 1, 0] and opt.n[0, 0].tolist() == [1, 0, 0]
    assert float(opt.q[0, 0, 1]) == 0.0
    # trial 3: option 2, s2 (3.9, -0.5), passed 0.4 m from it: credited
    opt.begin_trial(rows)
    _, option, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
    assert int(option[0]) == 2
    opt.steer(torch.tensor([0]), _odometry((3.5, -0.5, 0.0)), False)
    opt.learn(rows, torch.tensor([[-4.0, -1.0]], dtype=torch.float64))
    assert opt.n[0, 0].tolist() == [1, 0, 1] and float(opt.q[0, 0, 2]) == -4.0
    # with credit "all" the unreached trial would have counted -30 for option 1
    every = _options(epsilon=0.0, reach=0.25)
    for _ in range(2):
        every.begin_trial(rows)
        every.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
        every.learn(rows, torch.tensor([[-30.0, -1.0]], dtype=torch.float64))
    assert float(every.q[0, 0, 1]) == -30.0


def test_reached_credit_in_a_batch_counts_each_robots_own_approach():
    # 3 robots on the 2-region table (batch != regions): robot 0 takes the goal option, robot 1
    # s1 and passes it, robot 2 s2 and never comes near it
    opt = _options(batch=3, epsilon=0.0, credit="reached", credit_radius=0.5)
    opt.tries[:, 0, 0] = opt.n[:, 0, 0] = 1
    opt.tries[0, 0, 1:] = 1  # robot 0 has tried everything but only the goal counts: greedy goal
    opt.tries[1, 0, 2] = 1  # robot 1's untried s1 first; robot 2's untried s2 (after s1) ...
    opt.tries[2, 0, 1] = 1
    rows = torch.arange(3)
    _, option, _ = opt.steer(
        torch.zeros(3, dtype=torch.long), _odometry(*[(0.0, 0.0, 0.0)] * 3), False
    )
    assert option.tolist() == [0, 1, 2]
    opt.steer(torch.zeros(3, dtype=torch.long), _odometry((1.0, 0.0, 0.0), (3.4, -0.4, 0.0),
                                                          (1.0, 1.0, 0.0)), False)  # fmt: skip
    opt.learn(rows, torch.full((3, 2), -3.0, dtype=torch.float64))
    assert opt.n[:, 0].tolist() == [[2, 0, 0], [1, 1, 0], [1, 0, 0]]
    assert opt.tries[:, 0].tolist() == [[2, 1, 1], [1, 1, 1], [1, 1, 1]]


def test_planner_waypoint_rounds_the_partition_that_no_region_line_marks():
    # two_doors: the corridor's passage points lie west of the thin partition (x 6.0, up to
    # y 2.4); aiming at the goal from there runs up the west lane into its dead end. The
    # planner's last turn in the corridor, pushed 0.45 m out, lies past the partition's end.
    from symrl.knowledge.subgoals import _clearance

    world = load_map("two_doors")
    config = load_config("paper", ["options.subgoal_planner=true"]).options
    opt = SubgoalOptions(world, 1, config, [0])
    corridor = opt.region_names.index("corridor")
    path = opt.labels[corridor].index("path")
    x, y = opt.table.point(corridor, path)
    assert x > 6.0 and y < 2.4  # east of the partition, below its end
    assert _clearance(world, (x, y)) == pytest.approx(0.45, abs=1e-6)
    assert bool(opt.valid[corridor, path])
    plain = SubgoalOptions(world, 1, load_config("paper").options, [0])
    assert "path" not in plain.labels[corridor]
