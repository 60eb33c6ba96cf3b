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


# -- learned sub-goal positions -------------------------------------------------------------


def _search_policy(*overrides: str, seeds=(0,)):
    return policy("paper", "subgoal_search.enabled=true", "options.try_untried=false",
                  "options.epsilon=0", *overrides, seeds=seeds)  # fmt: skip


def _aim(p, greedy=False) -> float:
    obs = A.expand(p.batch).clone()
    region = p.mapper.ids(obs["odometry"][:, :2].double())
    return p.options.steer(region, obs["odometry"], greedy)[0]


def test_a_regions_point_moves_by_one_jitter_per_trial_and_its_learned_offset():
    p = _search_policy()
    search = p.options.search
    first = search.jitter.clone()
    assert first.abs().min() > 0
    room = p.region_names.index("room")
    aim = _aim(p)
    assert torch.equal(_aim(p), aim)  # the same trial: the same point
    plain = policy("paper", "options.try_untried=false", "options.epsilon=0")
    assert not torch.equal(_aim(plain), aim)
    p.options.choice.fill_(-1)
    search.jitter.zero_()
    assert torch.allclose(_aim(p), _aim(plain))  # no jitter, no offset: the map's point
    search.offset[0, room, 0] = torch.tensor([0.0, 0.2], dtype=torch.float64)
    p.options.choice.fill_(-1)
    assert not torch.allclose(_aim(p, greedy=True), _aim(plain, greedy=True))
    p.options.trials += 1
    p.begin_trial(torch.tensor([0]))
    assert not torch.equal(search.jitter, first)
    p.options.trials -= 1
    p.begin_trial(torch.tensor([0]))
    assert torch.equal(search.jitter, first)  # drawn from the seed and the trial
    sigma = _search_policy("subgoal_search.sigma=0.2").options.search.jitter
    assert torch.allclose(sigma, 2 * first)
    batch = _search_policy(seeds=(3, 0)).options.search.jitter
    assert torch.equal(batch[1], first[0])


@pytest.mark.parametrize("ret, sign", [(-1.0, 1.0), (-3.0, -1.0)])
def test_the_offset_steps_toward_a_jitter_that_beat_the_critic(ret, sign):
    p = _search_policy("subgoal_search.rate=0.5")
    opts, search = p.options, p.options.search
    opts.choice[0] = torch.tensor([1, -1, -1, -1])  # the room chose option 1
    opts.q[0, 0, 1], opts.n[0, 0, 1] = -2.0, 3
    jitter = search.jitter[0, 0].clone()
    opts.learn(torch.tensor([0]), torch.tensor([[ret, 0.0, 0.0, 0.0]], dtype=torch.float64))
    assert torch.allclose(search.offset[0, 0, 1], sign * 0.5 * 1.0 * jitter)
    search.offset[0, 0, 1] = 0.0
    assert not search.offset.any()  # no other option or region moved


def test_the_offset_stays_within_max_shift_and_is_saved():
    p = _search_policy("subgoal_search.rate=100", "subgoal_search.max_shift=0.25")
    opts, search = p.options, p.options.search
    opts.choice[0] = torch.tensor([2, -1, -1, -1])
    opts.q[0, 0, 2], opts.n[0, 0, 2] = -5.0, 1
    opts.learn(torch.tensor([0]), torch.tensor([[-3.0, 0.0, 0.0, 0.0]], dtype=torch.float64))
    assert float(torch.linalg.vector_norm(search.offset[0, 0, 2])) == pytest.approx(0.25)
    state = p.robot_state(0)
    assert torch.equal(state["options.search.offset"], search.offset)
    fresh = _search_policy()
    fresh.load_state_dict(state)
    assert torch.equal(fresh.options.search.offset, search.offset)


def test_search_needs_options():
    with pytest.raises(ConfigError, match="subgoal_search.enabled=true needs"):
        load_config("paper", ["subgoal_search.enabled=true", "options.enabled=false"])


def test_a_loaded_controller_acts_with_the_kicks_and_jitters_of_its_trial():
    p = _with_neuron("subgoal_search.enabled=true")
    p.trials_done += 2
    p.options.trials += 2
    p.begin_trial(torch.tensor([0]))
    kick, jitter = _kick(p), p.options.search.jitter.clone()
    fresh = _with_neuron("subgoal_search.enabled=true")
    fresh.load_state_dict(p.state_dict())
    assert torch.equal(_kick(fresh), kick) and float(kick[0]) != 0.0
    assert torch.equal(fresh.options.search.jitter, jitter)
