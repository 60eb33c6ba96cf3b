"""The TESEO update against an autograd formulation of the same losses, growth, end of trial."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from learner_helpers import obs, obs_td, transition

from symrl.learner.loss import TeseoLoss


def _two_neurons(make_policy, u_prev=-1.0, u_next=-2.0, mu=0.1, **cfg):
    """A policy with neuron 0 at state A (the previous winner) and neuron 1 at state B."""
    p = make_policy(**cfg)
    a, b = obs(sonar=0.3), obs(sonar=0.6)
    for o, u in ((a, u_prev), (b, u_next)):
        x = p.encode(o.sonar, o.goal[0])
        p.experts[0].add(x, action=0.0, utility=u, mean=mu)
    return p, a, b


def _oracle(u_prev, u_next, mu, sigma, xi, r, gamma, eta, beta):
    """One SGD step on 1/2 delta^2 (target detached, lr eta) and on
    -delta * log N(xi; mu, sigma^2) (delta detached, lr beta * sigma^2)."""
    u = torch.tensor(u_prev, dtype=torch.float64, requires_grad=True)
    m = torch.tensor(mu, dtype=torch.float64, requires_grad=True)
    target = torch.tensor(r + gamma * u_next, dtype=torch.float64)
    delta = target - u
    (0.5 * delta**2).backward()
    d = delta.detach()
    (-d * torch.distributions.Normal(m, sigma).log_prob(torch.tensor(xi))).backward()
    with torch.no_grad():
        return float(u - eta * u.grad), float(m - beta * sigma**2 * m.grad), float(d)


@pytest.mark.parametrize("r", [-0.4, -2.2])  # delta > 0 (centre shift) and delta < 0
def test_update_matches_autograd_oracle(make_policy, r):
    p, a, b = _two_neurons(make_policy, u_prev=-1.0, u_next=-0.5, mu=0.1)
    loss = TeseoLoss(p)
    c_before = p.experts[0].centres[0].clone()
    td = transition(p, a, b, reward=r)
    assert int(td["winner"][0]) == 0
    xi, sigma = float(td["xi"][0]), float(td["sigma"][0])
    cfg = p.config
    u_new, mu_new, delta = _oracle(-1.0, -0.5, 0.1, sigma, xi, r, cfg.gamma, cfg.eta, cfg.beta)
    out = loss(td)
    rows = p.experts[0].rows
    assert float(out["td_error"]) == pytest.approx(delta, abs=1e-6)
    assert rows.utilities[0] == pytest.approx(u_new, abs=1e-6)
    assert rows.means[0] == pytest.approx(mu_new, abs=1e-6)
    x = td["x"][0]
    if delta > 0:  # c += kappa (x - c): a gradient step on 1/2 ||x - c||^2 with lr kappa
        c = c_before.clone().requires_grad_(True)
        (0.5 * (x - c).square().sum()).backward()
        expected = c_before - cfg.kappa * c.grad
        assert torch.allclose(p.experts[0].centres[0], expected, atol=1e-6)
    else:
        assert torch.equal(p.experts[0].centres[0], c_before)
    assert int(out["new_neurons"]) == 0 and len(p.experts[0]) == 2


def test_next_winner_is_held_for_the_next_action(make_policy):
    p, a, b = _two_neurons(make_policy)
    loss = TeseoLoss(p)
    loss(transition(p, a, b, reward=-0.3))
    td = p(obs_td(b))
    assert int(td["winner"]) == 1 and p._held is None


def test_terminated_bootstraps_zero_truncated_does_not(make_policy):
    p, a, b = _two_neurons(make_policy, u_prev=-1.0, u_next=-0.5)
    out = TeseoLoss(p)(transition(p, a, b, reward=-0.3, terminated=True))
    assert float(out["td_error"]) == pytest.approx(-0.3 + 1.0)
    p, a, b = _two_neurons(make_policy, u_prev=-1.0, u_next=-0.5)
    out = TeseoLoss(p)(transition(p, a, b, reward=-0.3, truncated=True))
    assert float(out["td_error"]) == pytest.approx(-0.3 + 0.95 * -0.5 + 1.0)
    # a truncated trial grows nothing at its final state
    p, a, _ = _two_neurons(make_policy)
    out = TeseoLoss(p)(transition(p, a, obs(sonar=0.95), reward=-0.3, truncated=True))
    assert len(p.experts[0]) == 2 and int(out["new_neurons"]) == 0


def test_distance_driven_growth_at_the_next_state(make_policy):
    p, a, _ = _two_neurons(make_policy)
    new = obs(sonar=0.95, goal=(4.0, 0.4))
    out = TeseoLoss(p)(transition(p, a, new, reward=-0.7))
    e = p.experts[0]
    assert len(e) == 3 and int(out["new_neurons"]) == 1
    assert e.rows.utilities[2] == pytest.approx(-0.7)  # u = r(state), the reward received
    assert e.rows.actions[2] == pytest.approx(float(p.reflex(new.sonar, torch.tensor(0.4))))


def test_error_driven_growth_instead_of_adaptation(make_policy):
    p, a, b = _two_neurons(make_policy, u_prev=-1.0, u_next=-0.5)
    td = transition(p, a, b, reward=-3.5)  # delta = -3.5 - 0.475 + 1 = -2.975
    out = TeseoLoss(p)(td)
    e = p.experts[0]
    delta = float(out["td_error"])
    assert abs(delta) > p.config.error_threshold and int(out["new_neurons"]) == 1
    assert len(e) == 3
    assert torch.equal(e.centres[2], td["x"][0])
    assert e.rows.utilities[2] == pytest.approx(-1.0 + delta, abs=1e-6)
    assert e.rows.utilities[0] == -1.0 and e.rows.means[0] == pytest.approx(0.1)


def _used_policy(make_policy):
    p, a, b = _two_neurons(make_policy)
    p(obs_td(a))  # neuron 0 acts: remembers the action taken
    return p, float(p.experts[0].rows.taken[0])


def test_action_replacement_only_after_a_better_successful_trial(make_policy):
    p, taken = _used_policy(make_policy)
    loss = TeseoLoss(p)
    rows = p.experts[0].rows
    loss.end_trial({"reached_goal": False, "total_reinforcement": -5.0})
    assert rows.actions[0] == 0.0 and rows.means[0] == pytest.approx(0.1)  # failed: nothing
    p(obs_td(obs(sonar=0.3)))
    info = loss.end_trial({"reached_goal": True, "total_reinforcement": -10.0})
    assert info["replaced"] == 1 and info["improved"]
    assert rows.actions[0] == pytest.approx(float(rows.taken[0])) and rows.means[0] == 0.0
    assert rows.actions[1] == 0.0  # not used this trial
    before = float(rows.actions[0])
    rows.means[0] = 0.3
    p(obs_td(obs(sonar=0.3)))
    info = loss.end_trial({"reached_goal": True, "total_reinforcement": -12.0})  # worse
    assert info["replaced"] == 0 and not info["improved"]
    assert rows.actions[0] == before and rows.means[0] == pytest.approx(0.3)
    assert float(p.best_total) == -10.0


def test_cooling_down_to_the_floor(make_policy):
    p = make_policy(temperature0=0.3, cooling=0.5, temperature_min=0.05)
    loss = TeseoLoss(p)
    temps = []
    for _ in range(6):
        loss.end_trial({"reached_goal": False, "total_reinforcement": -50.0})
        temps.append(float(p.temperature))
    assert temps[:2] == pytest.approx([0.15, 0.075])
    assert temps[2:] == pytest.approx([0.05] * 4)
    assert math.isclose(min(temps), 0.05)


# make_policy is a factory (each example builds its own policy), so sharing it is safe.
@settings(
    max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    u_prev=st.floats(-15.0, 0.0),
    u_next=st.floats(-15.0, 0.0),
    mu=st.floats(-0.5, 0.5),
    r=st.floats(-4.0, 0.0),
)
def test_update_matches_autograd_oracle_everywhere(make_policy, u_prev, u_next, mu, r):
    p, a, b = _two_neurons(make_policy, u_prev=u_prev, u_next=u_next, mu=mu)
    td = transition(p, a, b, reward=r)
    xi, sigma = float(td["xi"][0]), float(td["sigma"][0])
    cfg = p.config
    u_new, mu_new, delta = _oracle(u_prev, u_next, mu, sigma, xi, r, cfg.gamma, cfg.eta, cfg.beta)
    TeseoLoss(p)(td)
    rows = p.experts[0].rows
    if abs(delta) > cfg.error_threshold:  # error-driven growth instead of adaptation
        assert len(p.experts[0]) == 3 and rows.utilities[0] == pytest.approx(u_prev, abs=1e-5)
    else:
        assert rows.utilities[0] == pytest.approx(u_new, abs=1e-4)
        assert rows.means[0] == pytest.approx(mu_new, abs=1e-4)
