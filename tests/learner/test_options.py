"""SubgoalOptions on a hand-made table: the choice at a region's first entry, the averaging
(or best) critic, epsilon, reaching a sub-goal, and independence of the robots of a batch; told
the map, the route option on a small world."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from symrl.knowledge.route import ROUTE
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import OptionCriticConfig, OptionsConfig, load_config
from symrl.learner.options import SubgoalOptions
from symrl.world.worldmap import load_map, parse_map

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


_EXPLORE = set(OptionCriticConfig.model_fields)


def _options(batch: int = 1, seeds=None, **cfg) -> SubgoalOptions:
    """Options over :func:`_table` with the ``OptionsConfig`` and ``OptionCriticConfig``
    fields ``cfg``."""
    explore = OptionCriticConfig(**{k: v for k, v in cfg.items() if k in _EXPLORE})
    config = OptionsConfig(enabled=True, **{k: v for k, v in cfg.items() if k not in _EXPLORE})
    return SubgoalOptions(WORLD, batch, config, seeds or list(range(batch)), _table(), explore)


def _odometry(*poses) -> torch.Tensor:
    return torch.tensor(poses, dtype=torch.float32)


def _learn(opt: SubgoalOptions, rows: torch.Tensor, returns: torch.Tensor) -> None:
    """The update's critic step at the end of the trials of ``rows`` (as ``TeseoUpdate``)."""
    opt.critic.learn(rows.numpy(), opt.trial_choices(rows.numpy()), returns.numpy())


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
    config = OptionsConfig(enabled=True, goal_lead_deg=20.0)
    stages = []
    for name, tab, sign in (("hailu2001", table, 1.0), ("hailu2001_mirror", mirrored, -1.0)):
        opt = SubgoalOptions(load_map(name), 1, config, [0], tab, OptionCriticConfig(epsilon=0))
        opt.critic.n[0, 0] = 1
        opt.critic.q[0, 0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
        row = []
        for x, y in ((0.0, 0.0), (3.0, 0.5), (2.0, -1.5)):
            opt.steer(torch.tensor([0]), _odometry((x, sign * y, 0.0)), False)
            row.append(int(opt.stage[0]))
        stages.append(row)
    assert stages[0] == stages[1] == [0, 0, 1]


@pytest.mark.parametrize("lead, expected", [(0.0, (3.5, -0.5)), (15.0, (3.5, -0.5)), (20.0, GOAL)])
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
        opt = _options(
            len(seeds), seeds, epsilon=1.0, epsilon_decay=1.0, greedy_after=0, try_untried=False
        )
        row = seeds.index(seed)
        out = []
        for _ in range(30):
            rows = torch.arange(len(seeds))
            opt.begin_trial(rows)
            _, option, _, _, _ = opt.steer(
                torch.zeros(len(seeds), dtype=torch.long),
                _odometry(*[(0.0, 0.0, 0.0)] * len(seeds)),
                False,
            )
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


# -- the route option (knowledge: map) ---------------------------------------------------------
# a 4 m box split by a thin wall from the floor up to y = 1: the way from the west to the goal in
# the east goes over the wall's end
WALL = parse_map(
    {
        "name": "wall_end",
        "boundary": [[-2, -2], [2, -2], [2, 2], [-2, 2]],
        "segments": [[[0.0, -2.0], [0.0, 1.0]]],
        "start": {"x": -1.5, "y": -1.5},
        "goal": {"x": 1.5, "y": -1.5, "radius": 0.2},
        "regions": {
            "names": ["west", "east"],
            "lines": {"m": {"x": 0.0}},
            "rules": [{"region": "west", "when": ["x < m"]}, {"region": "east"}],
        },
    }
)
WEST, EAST = 0, 1


def _route_options(**cfg) -> SubgoalOptions:
    """Greedy options on WALL whose critic prefers the route everywhere (tried, best)."""
    config = OptionsConfig(enabled=True, **cfg)
    opt = SubgoalOptions(
        Knowledge.told(WALL, "map"), 1, config, [0], explore=OptionCriticConfig(epsilon=0.0)
    )
    opt.critic.n[0] = 1
    opt.critic.q[0] = -5.0
    opt.critic.q[0, :, 0] = -1.0
    return opt


def _aim(opt: SubgoalOptions, region: int, x: float, y: float) -> tuple[int, np.ndarray]:
    _, option, _, point, _ = opt.steer(torch.tensor([region]), _odometry((x, y, 0.0)), False)
    return int(option[0]), point[0].numpy()


def test_told_the_map_each_region_has_the_route_beside_the_passage_options():
    opt = _route_options()
    assert opt.labels == [[ROUTE, "goal", "m>east"], [ROUTE, "goal"]]
    assert opt.table.point(WEST, 2) == pytest.approx((0.4, 1.5))  # past the wall's end


def test_the_route_aims_ahead_on_the_shortest_path_from_where_the_robot_is():
    opt = _route_options(ahead=0.6)
    option, aim = _aim(opt, WEST, -1.5, -1.5)
    assert option == 0 and opt.route is not None and opt.route.plans == 1
    # 0.6 m along the first leg, which runs from the start up to the wall's end (0, 1)
    assert math.dist(aim, (-1.5, -1.5)) == pytest.approx(0.6, abs=0.03)
    leg = np.array([0.0, 1.0]) - np.array([-1.5, -1.5])
    off = aim - (-1.5, -1.5)
    assert leg[0] * off[1] - leg[1] * off[0] == pytest.approx(0.0, abs=0.2)
    assert bool(WALL.in_free_area(*aim)) and aim[1] > -1.5
    # a step along the path: the same plan, the aim 0.2 m further on
    step = np.array((-1.5, -1.5)) + 0.2 * leg / np.linalg.norm(leg)
    _, later = _aim(opt, WEST, *step)
    assert opt.route.plans == 1 and math.dist(later, aim) == pytest.approx(0.2, abs=0.06)


def test_the_route_is_re_planned_once_the_robot_has_left_the_path():
    opt = _route_options(ahead=0.6)
    _aim(opt, WEST, -1.5, -1.5)
    _, aim = _aim(opt, WEST, -1.5, 1.5)  # far off the first path: planned again from here
    assert opt.route is not None and opt.route.plans == 2
    assert math.dist(aim, (-1.5, 1.5)) == pytest.approx(0.6, abs=0.03)
    assert aim[0] > -1.5 and bool(WALL.in_free_area(*aim))  # toward the wall's end, east
    # past the wall the route leads down to the goal; a new trial plans from the start again
    _, east = _aim(opt, EAST, 0.4, 1.4)
    assert east[1] < 1.4 and opt.route.plans == 3
    opt.begin_trial(torch.tensor([0]))
    _aim(opt, WEST, -1.5, -1.5)
    assert opt.route.plans == 4


def test_a_timed_out_option_gives_way_and_the_route_does_not_time_out():
    opt = _route_options(region_limit=3)
    opt.choice[0, WEST] = 1  # the goal: into the wall
    for _ in range(3):
        assert _aim(opt, WEST, -1.0, -1.0)[0] == 1
    assert _aim(opt, WEST, -1.0, -1.0)[0] == 0  # past the limit: the best left, the route
    assert opt.critic.stalled[0, WEST].tolist() == [False, True, False]
    for _ in range(10):  # re-planned, never given up
        assert _aim(opt, WEST, -1.0, -1.0)[0] == 0
    assert opt.trial_choices(np.array([0])).tolist() == [[0, -1]]


def test_on_the_route_the_start_turn_applies_at_every_step():
    """The reflex turns at most 45 degrees an action: on the route a robot whose aim lies more
    than start_turn_deg off its heading turns straight at it, not only on the trial's first
    step; on another option only on the first step."""
    opt = _route_options(start_turn_deg=90.0)
    region = torch.tensor([WEST])

    def turn(heading: float) -> bool:
        return bool(opt.steer(region, _odometry((-1.5, -1.5, heading)), False)[4][0])

    assert turn(0.6) is False  # the aim (up and right) lies within 90 degrees
    assert turn(math.pi + 1.0) is True  # a later step, the aim behind: on the route, turn
    opt.begin_trial(torch.tensor([0]))
    opt.choice[0, WEST] = 1  # the goal, as the option of the region
    assert turn(math.pi) is True  # the trial's first step
    assert turn(math.pi) is False  # a later step: the reflex turns


def _steps_on_each_option(opt: SubgoalOptions, steps: int) -> list[tuple[int, int]]:
    """Robot 0 held at the origin in region 0 for ``steps`` actions: the options in force, in
    order, with the actions each was in force."""
    runs: list[tuple[int, int]] = []
    for _ in range(steps):
        _, option, _, _, _ = opt.steer(torch.tensor([0]), _odometry((0.0, 0.0, 0.0)), False)
        o = int(option[0])
        if runs and runs[-1][0] == o:
            runs[-1] = (o, runs[-1][1] + 1)
        else:
            runs.append((o, 1))
    return runs


def test_a_timeout_scaled_by_the_aims_distance_gives_a_far_aim_the_actions_it_needs():
    """region_limit_scale: an option is given up after scale x (the straight way to its aim
    when chosen, over the step length) actions in its region, at least region_limit; without it,
    after region_limit actions whatever the distance."""
    step = 0.2  # the robot's step (m)
    goal, s1 = math.hypot(4.0, -2.0), math.hypot(3.5, -0.5)  # option 0's and 1's aims from (0, 0)
    scaled = _options(region_limit=3, region_limit_scale=1.5)
    runs = _steps_on_each_option(scaled, 70)
    # the option chosen at a timeout steers from that action on, then its own limit's actions
    first, second = math.floor(1.5 * goal / step), 1 + math.floor(1.5 * s1 / step)
    assert runs[:2] == [(0, first), (1, second)]
    assert _steps_on_each_option(_options(region_limit=3), 8)[:2] == [(0, 3), (1, 4)]
    # an aim nearer than region_limit's worth of actions keeps region_limit
    near = _options(region_limit=40, region_limit_scale=1.5)
    assert _steps_on_each_option(near, 45)[0] == (0, 40)


def test_the_scaled_timeout_needs_the_timeout():
    with pytest.raises(ValueError, match=r"options.region_limit_scale=1.5 .* options.region_limit"):
        load_config("paper", ["options.region_limit_scale=1.5", "options.region_limit=null"])


@pytest.mark.parametrize("shortest, tried", [(20.0, False), (40.0, True)])
def test_an_untried_option_is_tried_only_while_it_could_beat_the_shortest_trial(shortest, tried):
    # from (0, 0) by s1 (3.5, -0.5) to the goal disc: 3.54 m + 1.58 m - radius, ~23 actions
    opt = _options(epsilon=0.0, try_if_shorter=True)
    assert _trial(opt, {0: -10.0}) == 0  # no trial has reached the goal yet: untried first
    opt.critic.finish(np.array([0]), np.array([shortest]), np.array([True]))
    assert _trial(opt, {0: -10.0, 1: -5.0, 2: -5.0}) == (1 if tried else 0)


@pytest.mark.parametrize("shortest, drawn", [(23.0, {0}), (24.0, {0, 1}), (40.0, {0, 1, 2})])
def test_an_epsilon_draw_takes_only_options_that_could_beat_the_shortest_trial(shortest, drawn):
    # from (0, 0) the goal lies 22.4 actions off (option 0), by s1 23.6 (option 1), by s2 25.2
    opt = _options(epsilon=1.0, epsilon_decay=1.0, try_untried=False, try_if_shorter=True)
    opt.critic.finish(np.array([0]), np.array([shortest]), np.array([True]))
    assert {_trial(opt, {0: -10.0, 1: -5.0, 2: -5.0}) for _ in range(30)} == drawn


def test_the_critic_keeps_the_shortest_trial_that_reached_the_goal():
    opt = _options(try_if_shorter=True)
    critic = opt.critic
    assert critic.tracks_shortest and critic.shortest_trial(0) == math.inf
    critic.finish(np.array([0]), np.array([30.0]), np.array([False]))  # missed: not counted
    assert critic.shortest_trial(0) == math.inf
    critic.finish(np.array([0]), np.array([30.0]), np.array([True]))
    critic.finish(np.array([0]), np.array([40.0]), np.array([True]))
    assert critic.shortest_trial(0) == 30.0
    assert not _options().critic.tracks_shortest


@pytest.mark.parametrize("shortest, tried", [(8.0, False), (10.0, True)])
def test_told_the_map_the_bound_is_the_planned_way_from_the_options_point(shortest, tried):
    # the concave region's way back to the room, (3.0, -0.6): 1.32 m straight to the goal disc
    # (6.6 actions), 1.86 m planned round the door post (9.3 actions)
    config = paper_map("option_critic.try_if_shorter=true", "option_critic.epsilon=0")
    opt = SubgoalOptions(WORLD, 1, config.options, [0], explore=config.option_critic)
    concave = opt.region_names.index("concave")
    way_back = opt.labels[concave].index("l1>room")
    assert opt.points[concave, way_back].tolist() == pytest.approx([3.0, -0.6])
    opt.critic.n[0, concave] = 1
    opt.critic.n[0, concave, way_back] = 0  # only the way back is untried
    opt.critic.finish(np.array([0]), np.array([shortest]), np.array([True]))
    _, option, *_ = opt.steer(torch.tensor([concave]), _odometry((3.0, -0.6, 0.0)), greedy=False)
    assert (int(option[0]) == way_back) == tried
