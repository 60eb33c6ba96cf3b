"""The policy: input coding, routing by region, growth from the reflex, exploration, greedy mode."""

from __future__ import annotations

import math

import pytest
import torch
from learner_helpers import obs, obs_td
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.learner.policy import MixtureOfExpertsPolicy

# One pose per region of the hailu2001 map (room, concave, door, corridor).
POSES = {
    "room": (0.0, 0.0, 0.0),
    "concave": (1.0, -2.0, 0.0),
    "door": (3.6, -0.5, 0.0),
    "corridor": (4.5, 0.5, 0.0),
}


def test_input_is_sonars_and_goal_codes(make_policy):
    p = make_policy()
    o = obs(sonar=0.25, goal=(p.start_distance * 0.5, 0.0))
    x = p.encode(o.sonar, o.goal[0])
    assert x.shape == (32,)
    assert torch.allclose(x[:24], torch.full((24,), 0.25))
    mu = torch.arange(8) / 7
    assert torch.allclose(x[24:], torch.exp(-((mu - 0.5) ** 2)))
    far = p.encode(o.sonar, torch.tensor(p.start_distance * 3))  # rho clipped to 1
    assert torch.allclose(far[24:], torch.exp(-((mu - 1.0) ** 2)))


def test_routing_by_region(make_policy):
    p = make_policy()
    assert p.expert_names == ("room", "concave", "door", "corridor")
    for name, pose in POSES.items():
        td = p(obs_td(obs(pose=pose)))
        assert int(td["expert"]) == p.expert_names.index(name)
        assert len(p.experts[p.expert_names.index(name)]) == 1
    assert p.neurons() == {"room": 1, "concave": 1, "door": 1, "corridor": 1}


def test_no_partition_uses_one_expert(make_policy):
    p = make_policy(partition=False)
    assert p.expert_names == ("all",)
    for name, pose in POSES.items():
        td = p(obs_td(obs(pose=pose, sonar=0.1 * (1 + list(POSES).index(name)))))
        assert int(td["expert"]) == 0 and int(td["region"]) == p.region_names.index(name)
    assert p.neurons() == {"all": 4}


def test_scalar_gate_agrees_with_region_mapper(make_policy):
    p = make_policy()
    g = torch.Generator().manual_seed(1)
    poses = torch.rand(500, 2, generator=g) * torch.tensor([7.5, 7.0]) - torch.tensor([1.8, 4.2])
    batched = p.mapper(poses)
    assert [p.region_of(tuple(q.tolist()) + (0.0,)) for q in poses] == batched.tolist()


def test_new_neuron_takes_reflex_action_and_state_utility(make_policy):
    p = make_policy()
    o = obs(sonar=0.5, goal=(4.0, 0.6))
    td = p(obs_td(o))
    e = p.experts[0]
    assert bool(td["grown"]) and len(e) == 1
    reflex = float(p.reflex(o.sonar, torch.tensor(0.6)))
    assert e.rows.actions[0] == pytest.approx(reflex, abs=1e-6)
    assert e.rows.utilities[0] == pytest.approx(-0.6 / math.pi, abs=1e-6)  # f1 = 0, f2
    assert e.rows.means[0] == 0.0
    # same situation again: no growth, same winner
    td = p(obs_td(o))
    assert not bool(td["grown"]) and int(td["winner"]) == 0 and len(e) == 1


def test_no_reflex_new_neurons_take_random_actions(make_policy):
    p = make_policy(reflex=False)
    actions = []
    for k in range(6):
        p(obs_td(obs(sonar=0.1 + 0.15 * k)))
        actions.append(float(p.experts[0].rows.actions[k]))
    assert len(set(actions)) == 6 and all(-math.pi <= a <= math.pi for a in actions)


def test_exploration_sigma_and_clipping(make_policy):
    p = make_policy(temperature0=0.3)
    o = obs()
    p(obs_td(o))
    rows = p.experts[0].rows
    rows.actions[0], rows.means[0], rows.utilities[0] = 0.2, 0.05, -1.0
    sigma = 0.3 / (1 + math.exp(-1.0))
    draws = []
    for _ in range(400):
        td = p(obs_td(o))
        assert float(td["sigma"]) == pytest.approx(sigma, rel=1e-6)
        xi = float(td["xi"])
        assert float(td["action"]) == pytest.approx(0.2 + xi, abs=1e-6)
        draws.append(xi)
    xs = torch.tensor(draws)
    assert abs(float(xs.mean()) - 0.05) < 4 * sigma / 20
    assert abs(float(xs.std()) - sigma) < 0.15 * sigma
    rows.actions[0] = 3.1
    rows.means[0] = 1.0
    assert float(p(obs_td(o))["action"]) == pytest.approx(math.pi)  # clipped (float32 pi)


def test_greedy_mode_is_p_plus_mu_and_read_only(make_policy):
    p = make_policy()
    o = obs()
    p(obs_td(o))
    rows = p.experts[0].rows
    rows.actions[0], rows.means[0] = 0.2, 0.05
    rows.used[0] = False
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        td = p(obs_td(o))
        assert float(td["action"]) == pytest.approx(0.25, abs=1e-6)
        novel = obs(sonar=0.9)
        td = p(obs_td(novel))  # unseen situation: the reflex's action, nothing stored
        assert float(td["action"]) == pytest.approx(float(p.reflex(novel.sonar, novel.goal[1])))
    assert p.total_neurons() == 1 and not bool(p.experts[0].used[0])


def test_reflex_only_drives_with_the_reflex(make_policy):
    p = make_policy(learning=False)
    o = obs(sonar=0.03, goal=(3.0, -1.0))
    td = p(obs_td(o))
    assert float(td["action"]) == pytest.approx(float(p.reflex(o.sonar, torch.tensor(-1.0))))
    assert p.total_neurons() == 0 and int(td["winner"]) == -1


def test_reflex_target_hook_changes_the_new_neurons_action(make_policy):
    class SubGoal(MixtureOfExpertsPolicy):
        def reflex_target(self, obs, expert):
            return 1.0

    base = make_policy()
    p = SubGoal(base.config, world="hailu2001")
    o = obs(goal=(4.0, -1.0))
    p(obs_td(o))
    assert p.experts[0].rows.actions[0] == pytest.approx(
        float(p.reflex(o.sonar, torch.tensor(1.0))), abs=1e-6
    )


def test_spec_covers_every_out_key(make_policy):
    p = make_policy()
    td = p(obs_td(obs()))
    assert set(p.spec.keys()) == set(p.out_keys)
    assert p.spec.is_in(td.select(*p.out_keys))
