"""The option learner: choice once per region and trial, averaged critic, epsilon schedule."""

from __future__ import annotations

import pytest
import torch

from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.options import OptionConfig, OptionLearner

GOAL = (4.0, -2.0)


def _table() -> SubgoalTable:
    """Two regions: region 0 has the goal and two sub-goals, region 1 only the goal."""
    points = torch.tensor([[[4.0, -2.0], [3.5, -0.5], [3.9, -0.5]], [[4.0, -2.0], [0, 0], [0, 0]]])
    valid = torch.tensor([[True, True, True], [True, False, False]])
    return SubgoalTable(("a", "b"), points, valid, [["goal", "s1", "s2"], ["goal"]])


def _trial(learner: OptionLearner, rewards_by_option: dict[int, float]) -> int:
    learner.target(0, 0.0, 0.0)
    option = learner.choice[0]
    learner.record(rewards_by_option[option])
    learner.target(1, 3.8, -0.5)
    learner.record(-1.0)
    learner.end_trial()
    return option


def test_untried_options_first_then_greedy_on_the_mean():
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0))
    chosen = [_trial(learner, {0: -10.0, 1: -5.0, 2: -7.0}) for _ in range(5)]
    assert chosen[:3] == [0, 1, 2]  # each untried option once, in table order
    assert chosen[3:] == [1, 1]
    # critic = mean return-to-go from the region's first entry (its own step + the rest)
    assert float(learner.q[0, 1]) == pytest.approx(-6.0)
    assert int(learner.n[0, 1]) == 3
    assert float(learner.q[1, 0]) == pytest.approx(-1.0)
    assert learner.greedy() == [1, 0]


def test_critic_averages_instead_of_keeping_the_best_trial():
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0))
    # option 1 has one lucky trial (-2) and then bad ones; option 2 is steadily -5
    outcomes = iter([-9.0, -2.0, -5.0, -12.0, -12.0, -12.0])
    for _ in range(6):
        learner.target(0, 0.0, 0.0)
        learner.record(next(outcomes) if learner.choice[0] != 2 else -5.0)
        learner.end_trial()
    assert learner.greedy()[0] == 2


def test_option_is_kept_for_the_whole_trial_and_reach_switches_to_the_goal():
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0, reach=0.25))
    learner.n[0] = 1  # pretend everything was tried: s1 best
    learner.q[0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    assert learner.target(0, 0.0, 0.0) == pytest.approx((3.5, -0.5))
    assert learner.target(1, 3.6, -0.5) == GOAL  # region b: only the goal
    assert learner.target(0, 3.4, -0.5) == GOAL  # re-entered a, within reach of s1
    assert learner.target(0, 3.0, -0.5) == GOAL  # reached: stays on the goal this visit
    assert learner.choice == {0: 1, 1: 0}


def test_epsilon_decays_and_greedy_after_cuts_exploration():
    cfg = OptionConfig(epsilon=1.0, epsilon_decay=0.5, greedy_after=3, try_untried=False)
    learner = OptionLearner(_table(), GOAL, cfg, torch.Generator().manual_seed(1))
    learner.n[0] = 1
    learner.q[0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    early = []
    for _ in range(3):
        early.append(learner.choose(0))
        learner.record(-1.0)
        learner.end_trial()
    assert learner.epsilon == pytest.approx(0.125)
    late = []
    for _ in range(10):
        late.append(learner.choose(0))
        learner.end_trial()
    assert set(late) == {1}


def test_epsilon_explores_and_is_deterministic_under_a_seed():
    def run(seed: int) -> list[int]:
        cfg = OptionConfig(epsilon=1.0, epsilon_decay=1.0, greedy_after=0, try_untried=False)
        learner = OptionLearner(_table(), GOAL, cfg, torch.Generator().manual_seed(seed))
        out = []
        for _ in range(30):
            out.append(learner.choose(0))
            learner.end_trial()
        return out

    assert run(3) == run(3)
    assert set(run(3)) == {0, 1, 2}


def test_gamma_discounts_the_return_to_go():
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0, gamma=0.5))
    learner.target(0, 0.0, 0.0)
    for r in (-1.0, -1.0, -1.0):
        learner.record(r)
    learner.end_trial()
    assert float(learner.q[0, 0]) == pytest.approx(-1.75)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"epsilon": 1.5},
        {"epsilon_decay": -0.1},
        {"greedy_after": -1},
        {"gamma": 0.0},
        {"prior": "best"},
        {"reach": -1.0},
        {"critic": "max"},
    ],  # fmt: skip
)
def test_config_rejects_bad_values(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        OptionConfig(**kwargs)


def test_best_critic_keeps_the_lucky_trial():
    """The literal reading (compare single trials) keeps a lucky -2 over a steady -5."""
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0, critic="best"))
    outcomes = iter([-9.0, -2.0, -5.0, -12.0, -12.0, -12.0])
    for _ in range(6):
        learner.target(0, 0.0, 0.0)
        learner.record(next(outcomes) if learner.choice[0] != 2 else -5.0)
        learner.end_trial()
    assert learner.greedy()[0] == 1
    assert float(learner.q[0, 1]) == pytest.approx(-2.0)


def test_greedy_flag_and_shared_buffers():
    q = torch.zeros(2, 3, dtype=torch.float64)
    n = torch.zeros(2, 3, dtype=torch.long)
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=1.0), q=q, n=n)
    n[0] = 1
    q[0] = torch.tensor([-9.0, -3.0, -1.0], dtype=torch.float64)
    assert learner.target(0, 0.0, 0.0, greedy=True) == pytest.approx((3.9, -0.5))
    learner.record(-4.0)
    learner.end_trial()
    assert int(n[0, 2]) == 2 and float(q[0, 2]) == pytest.approx(-2.5)  # updated in place
    with pytest.raises(ValueError, match="shape"):
        OptionLearner(_table(), GOAL, q=torch.zeros(3, 3, dtype=torch.float64))


def test_follow_up_point_before_the_goal():
    table = _table()
    table.then = torch.full((2, 3, 2), float("nan"))
    table.then[0, 1] = torch.tensor([3.9, -0.5])
    learner = OptionLearner(table, GOAL, OptionConfig(epsilon=0.0, reach=0.25))
    learner.n[0] = 1
    learner.q[0] = torch.tensor([-9.0, -1.0, -3.0], dtype=torch.float64)
    assert learner.target(0, 0.0, 0.0) == pytest.approx((3.5, -0.5))
    assert learner.target(0, 3.4, -0.5) == pytest.approx((3.9, -0.5))  # reached: go through
    assert learner.target(0, 3.5, -0.5) == pytest.approx((3.9, -0.5))
    assert learner.target(0, 3.8, -0.5) == GOAL  # follow-up reached


def test_collision_penalty_only_in_the_option_critic():
    learner = OptionLearner(_table(), GOAL, OptionConfig(epsilon=0.0, collision_penalty=5.0))
    learner.target(0, 0.0, 0.0)
    learner.record(-3.5, collision=True)
    learner.record(-0.5)
    learner.end_trial()
    assert float(learner.q[0, 0]) == pytest.approx(-9.0)
