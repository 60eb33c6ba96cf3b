"""Aim corrections: the experts' correction turns the bearing the reflex steers at. A zero
offset is today's reflex bit for bit, a known offset turns the aim by that much, the rule is
mirror-symmetric, the draw is held while a neuron wins, and the trial rule steps toward
exploration that beat the option critic."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from learner_helpers import observation, place, policy
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.knowledge.reflex import FuzzyReflex
from symrl.learner.aim import HeldDraws, aimed_bearing, trial_step
from symrl.learner.config import ConfigError, load_config
from symrl.learner.experts import ExpertBank

GREEDY = ExplorationType.DETERMINISTIC
AIM = ("aim.enabled=true", "options.enabled=false", "shield.enabled=false")
angles = st.floats(-3.0, 3.0, allow_nan=False)


@given(target=angles)
def test_a_zero_offset_returns_the_target_bit_for_bit(target):
    t = torch.tensor([target], dtype=torch.float64)
    assert torch.equal(aimed_bearing(t, torch.zeros(1, dtype=torch.float64), 0.8), t)


@given(target=st.floats(-2.0, 2.0), offset=st.floats(-0.8, 0.8))
def test_a_known_offset_turns_the_aim_by_that_much(target, offset):
    t = torch.tensor([target], dtype=torch.float64)
    turned = aimed_bearing(t, torch.tensor([offset], dtype=torch.float64), 0.8)
    assert float(turned[0]) == pytest.approx(target + offset, abs=1e-12)


def test_offsets_are_clipped_and_the_bearing_wrapped():
    t = torch.tensor([0.0, 3.0, -3.0], dtype=torch.float64)
    o = torch.tensor([2.0, 0.5, -0.5], dtype=torch.float64)
    out = aimed_bearing(t, o, 0.8).tolist()
    assert out[0] == pytest.approx(0.8)
    assert out[1] == pytest.approx(3.5 - 2 * math.pi)
    assert out[2] == pytest.approx(-3.5 + 2 * math.pi)


@settings(max_examples=50, deadline=None)
@given(
    target=st.floats(-2.5, 2.5),
    offset=st.floats(-0.6, 0.6),
    sonar=st.lists(st.floats(0.0, 1.0), min_size=24, max_size=24),
)
def test_mirror_symmetry_holds(target, offset, sonar):
    """Mirrored sonars, goal bearing and offset give the negated action."""
    reflex = FuzzyReflex(load_config("paper").reflex)
    s = torch.tensor([sonar], dtype=torch.float64)
    mirrored = s[:, [(-k) % 24 for k in range(24)]]
    t = torch.tensor([target], dtype=torch.float64)
    o = torch.tensor([offset], dtype=torch.float64)
    a = reflex(s, aimed_bearing(t, o, 0.8))
    b = reflex(mirrored, aimed_bearing(-t, -o, 0.8))
    assert float(b[0]) == pytest.approx(-float(a[0]), abs=1e-9)


def test_with_zero_offsets_the_policy_acts_as_the_output_correction_does():
    """No exploration and no learned offset: aim corrections and output corrections both drive
    with the reflex's action, bit for bit, on a whole trajectory of states."""
    aim = policy("paper", "update.temperature0=0", "aim.enabled=true")
    out = policy("paper", "update.temperature0=0")
    for sonar, pose in [(0.5, (0.0, 0.0, 0.0)), (0.2, (3.6, -0.5, 0.4)), (0.8, (4.5, 0.5, 1.0))]:
        obs = observation(sonar=sonar, pose=pose)
        a, b = aim(obs.clone()), out(obs.clone())
        assert torch.equal(a["action"], b["action"])


def test_a_neurons_offset_turns_the_reflexs_aim():
    p = policy("paper", *AIM)
    obs = observation(sonar=0.5, goal=(4.0, 0.3))
    place(p, obs, action=0.0, mean=0.4)  # the neuron's learned offset: 0.4 rad left
    with set_exploration_type(GREEDY):
        td = p(obs.clone())
    expected = p.reflex(obs["sonar"].double(), torch.tensor([0.3 + 0.4], dtype=torch.float64))
    assert float(td["action"][0, 0]) == pytest.approx(float(expected[0]), abs=1e-6)
    assert float(td["taken"][0]) == pytest.approx(0.4)  # the offset, before its clip
    clipped = policy("paper", *AIM, "aim.limit=0.1")
    place(clipped, obs, action=0.0, mean=0.4)
    with set_exploration_type(GREEDY):
        td = clipped(obs.clone())
    expected = p.reflex(obs["sonar"].double(), torch.tensor([0.3 + 0.1], dtype=torch.float64))
    assert float(td["action"][0, 0]) == pytest.approx(float(expected[0]), abs=1e-6)


def test_the_draw_is_held_while_the_same_neuron_wins():
    held = HeldDraws(2)
    key = HeldDraws.keys(torch.tensor([0, 1]), torch.tensor([3, 3]))
    first = held.hold(key, torch.tensor([0.5, -0.5], dtype=torch.float64))
    again = held.hold(key, torch.tensor([9.0, 9.0], dtype=torch.float64))
    assert first.tolist() == again.tolist() == [0.5, -0.5]
    other = HeldDraws.keys(torch.tensor([0, 1]), torch.tensor([3, 4]))  # robot 1: a new neuron
    assert held.hold(other, torch.tensor([1.0, 2.0], dtype=torch.float64)).tolist() == [0.5, 2.0]
    held.forget(torch.tensor([0]))  # robot 0 starts a trial: a fresh draw
    assert held.hold(other, torch.tensor([7.0, 8.0], dtype=torch.float64)).tolist() == [7.0, 2.0]


def test_the_policy_holds_its_exploration_on_one_neuron():
    p = policy("paper", *AIM, "update.temperature0=0.3")
    obs = observation()
    place(p, obs)
    xis = [float(p(obs.clone())["xi"][0]) for _ in range(4)]
    assert len(set(xis)) == 1 and xis[0] != 0.0
    free = policy("paper", *AIM, "update.temperature0=0.3", "aim.hold=false")
    place(free, obs)
    assert len({float(free(obs.clone())["xi"][0]) for _ in range(4)}) == 4


def test_trial_step_moves_used_neurons_toward_exploration_that_beat_the_critic():
    bank = ExpertBank(1, 2, 4)
    for e in (0, 1):
        for _ in range(2):
            bank.add(torch.tensor([0]), torch.tensor([e]), torch.zeros(1, 4),
                     torch.zeros(1, dtype=torch.float64), torch.zeros(1, dtype=torch.float64))
    bank.means[0, :, :2] = 0.1
    bank.taken[0, :, :2] = 0.3  # explored +0.2 above the mean
    bank.used[0, 0, 0] = bank.used[0, 1, 0] = True
    returns = torch.tensor([[-5.0, -1.0]], dtype=torch.float64)
    baseline = torch.tensor([[-6.0, -4.0]], dtype=torch.float64)  # both beat the critic
    trial_step(bank, torch.tensor([0]), returns, baseline, rate=0.5, clip=2.0, limit=0.8)
    assert bank.means[0, 0, 0].item() == pytest.approx(0.1 + 0.5 * 1.0 * 0.2)
    assert bank.means[0, 1, 0].item() == pytest.approx(0.1 + 0.5 * 2.0 * 0.2)  # clipped 3 -> 2
    assert bank.means[0, :, 1].tolist() == [0.1, 0.1]  # unused neurons keep their means
    bank.taken[0, 1, 0] = 5.0  # a huge exploration: the mean stops at the offset's limit
    trial_step(bank, torch.tensor([0]), returns, baseline, rate=0.5, clip=2.0, limit=0.8)
    assert bank.means[0, 1, 0].item() == pytest.approx(0.8)


def test_aim_needs_residual_experts_and_the_trial_rule_needs_options():
    with pytest.raises(ConfigError, match="aim.enabled=true needs experts.residual"):
        load_config("paper", ["aim.enabled=true", "experts.residual=false"])
    with pytest.raises(ConfigError, match="options.enabled"):
        load_config("paper", ["aim.enabled=true", "aim.learn=trial", "options.enabled=false"])
