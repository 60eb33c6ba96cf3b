"""Exploration held constant over a trial: one kick per neuron and trial, drawn from the seed
and the trial number, and the end-of-trial step toward a kick that beat the option critic."""

from __future__ import annotations

import pytest
import torch
from learner_helpers import observation, place, policy, transition
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.learner.config import ConfigError, load_config
from symrl.learner.loss import TeseoLoss
from symrl.learner.trial_exploration import option_advantage

ON = ("trial_exploration.enabled=true", "update.temperature0=0", "update.beta=0")
A = observation(sonar=0.5)  # the start pose: the room


def _with_neuron(*overrides: str, seeds=(0,)):
    p = policy("paper", *ON, "options.try_untried=false", "options.epsilon=0", *overrides,
               seeds=seeds)  # fmt: skip
    for row in range(p.batch):
        place(p, A, row=row)
    return p


def _kick(p, obs=A) -> torch.Tensor:
    return p(obs.expand(p.batch).clone())["kick"]


def test_a_kick_is_constant_within_a_trial_and_redrawn_at_the_next():
    p = _with_neuron()
    first = _kick(p)
    assert float(first[0]) != 0.0
    assert torch.equal(_kick(p), first)  # the same neuron, the same trial: the same kick
    # without per-step exploration the action is the reflex plus the kick
    td = p(A.clone())
    reflex = p.reflex(A["sonar"].double(), p.options.steer(td["region"], A["odometry"], True)[0])
    assert float(td["action"][0]) == pytest.approx(float(reflex[0] + first[0]), abs=1e-6)
    p.trials_done += 1
    p.begin_trial(torch.tensor([0]))
    second = _kick(p)
    assert float(second[0]) != float(first[0])
    p.trials_done -= 1  # the same trial number draws the same kick again
    p.begin_trial(torch.tensor([0]))
    assert torch.equal(_kick(p), first)


def test_kicks_do_not_depend_on_the_batch_and_scale_with_sigma():
    alone = _kick(_with_neuron(seeds=(5,)))
    batch = _kick(_with_neuron(seeds=(3, 5)))
    assert float(batch[1]) == float(alone[0]) and float(batch[0]) != float(alone[0])
    double = _kick(_with_neuron("trial_exploration.sigma=0.2", seeds=(5,)))
    assert float(double[0]) == pytest.approx(2 * float(alone[0]))
    p = _with_neuron("trial_exploration.decay=0.5", seeds=(5,))
    p.trials_done += 2
    p.begin_trial(torch.tensor([0]))
    assert p.perturbation.sigma(2) == pytest.approx(0.025)


def test_no_kick_for_a_novel_state_or_when_greedy_or_when_off():
    p = _with_neuron()
    far = observation(sonar=0.5, pose=(1.5, 1.5, 0.0))  # 2 m from the neuron: novel
    td = p(far.clone())
    assert bool(td["novel"][0]) and float(td["kick"][0]) == 0.0
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        assert float(_kick(p)[0]) == 0.0
    off = policy("paper")
    place(off, A)
    assert off.perturbation is None and float(off(A.clone())["kick"][0]) == 0.0


@pytest.mark.parametrize("reward, sign", [(-1.0, 1.0), (-3.0, -1.0), (6.0, 1.0)])
def test_the_mean_moves_toward_a_kick_that_beat_the_critic_and_away_from_one_that_lost(
    reward, sign
):
    p = _with_neuron("trial_exploration.rate=0.5", "trial_exploration.clip=2")
    loss = TeseoLoss(p)
    assert "kick" in loss.in_keys
    room = p.region_names.index("room")
    td = p(A.clone())
    kick = float(td["kick"][0])
    option = int(td["option"][0])
    td["next"] = transition(p, A, A, reward)["next"]
    loss(td)
    assert float(p.experts.means[0, room, 0]) == 0.0  # no per-step step (beta 0)
    p.options.q[0, room, option] = -2.0  # the option's mean return-to-go so far
    p.options.n[0, room, option] = 1
    loss.end_trial(torch.tensor([0]), torch.tensor([reward]), torch.tensor([True]))
    advantage = min(abs(reward + 2.0), 2.0)  # clipped at 2
    expected = sign * 0.5 * advantage * kick
    assert float(p.experts.means[0, room, 0]) == pytest.approx(expected)


def test_no_step_without_a_baseline_or_for_a_neuron_that_did_not_act():
    p = _with_neuron()
    loss = TeseoLoss(p)
    room = p.region_names.index("room")
    other = place(p, observation(sonar=0.5, pose=(1.5, 1.5, 0.0)))
    td = p(A.clone())
    td["next"] = transition(p, A, A, -1.0)["next"]
    loss(td)
    loss.end_trial(torch.tensor([0]), torch.tensor([-1.0]), torch.tensor([True]))
    assert not p.experts.means.any()  # the option had no critic yet: no baseline, no step
    p.begin_trial(torch.tensor([0]))
    td = p(A.clone())
    td["next"] = transition(p, A, A, -1.0)["next"]
    loss(td)
    loss.end_trial(torch.tensor([0]), torch.tensor([-0.5]), torch.tensor([True]))
    assert float(p.experts.means[0, room, 0]) == 0.0  # G = q: no advantage
    assert float(p.experts.means[0, room, other]) == 0.0


def test_option_advantage_is_zero_where_no_region_was_entered():
    p = _with_neuron()
    opts = p.options
    opts.choice[0] = torch.tensor([1, -1, 0, -1])
    opts.q[0, 0, 1], opts.n[0, 0, 1] = -4.0, 2
    adv = option_advantage(opts, torch.tensor([0]), torch.tensor([[-3.0, -9.0, -1.0, -9.0]]))
    assert adv.tolist() == [[1.0, 0.0, 0.0, 0.0]]  # the door's option: never finished


def test_needs_options_and_the_partition():
    with pytest.raises(ConfigError, match="trial_exploration.enabled=true needs"):
        load_config("paper", ["trial_exploration.enabled=true", "options.enabled=false"])
