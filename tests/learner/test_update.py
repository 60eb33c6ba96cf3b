"""The TESEO update on hand-built transitions: against autograd, growth, the bootstrap target,
renamed keys, batches, and the end of a trial (replacement, cooling, option critics)."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from learner_helpers import POSES, act, config_of, observation, place, policy, teseo, transition
from tensordict import TensorDictBase

from symrl.learner.update import TeseoUpdate

A, B = observation(sonar=0.3), observation(sonar=0.6)  # two room states 1.5 apart
FAR = observation(sonar=0.95, goal=(2.0, 0.4))  # novel: no neuron within the radius


def _two_neurons(*overrides: str, u_prev=-1.0, u_next=-0.5, mu=0.1):
    """A paper_literal policy with neuron 0 at A (the previous winner) and neuron 1 at B."""
    p = policy("paper_literal", *overrides)
    assert place(p, A, action=0.2, utility=u_prev, mean=mu) == 0
    assert place(p, B, action=-0.2, utility=u_next) == 1
    return p


def _oracle(u_prev, u_next, mu, sigma, xi, r, gamma, eta, beta):
    """One SGD step on 1/2 delta^2 (target detached, lr eta) and one on
    -delta * log N(xi; mu, sigma^2) (delta detached, lr beta * sigma^2)."""
    u = torch.tensor(u_prev, dtype=torch.float64, requires_grad=True)
    m = torch.tensor(mu, dtype=torch.float64, requires_grad=True)
    target = torch.tensor(r + gamma * u_next, dtype=torch.float64)
    delta = target - u
    (0.5 * delta**2).backward()
    d = delta.detach()
    normal = torch.distributions.Normal(m, torch.tensor(sigma, dtype=torch.float64))
    (-d * normal.log_prob(torch.tensor(xi, dtype=torch.float64))).backward()
    with torch.no_grad():
        return float(u - eta * u.grad), float(m - beta * sigma**2 * m.grad), float(d)


def _room(p) -> int:
    return p.region_names.index("room")


@pytest.mark.parametrize("r", [-0.4, -2.2])  # delta > 0 (centre shift) and delta < 0
def test_update_matches_autograd(r):
    p = _two_neurons()
    update = teseo(p)
    e = _room(p)
    x = p.perceive(A["sonar"], A["odometry"], A["goal"]).x[0] + 0.05  # off the centre
    c_before = p.experts.centres[0, e, 0].clone()
    xi, sigma = 0.35, 0.2
    u = config_of(p).update
    u_new, mu_new, delta = _oracle(-1.0, -0.5, 0.1, sigma, xi, r, u.gamma, u.eta, u.beta)
    out = update(transition(p, A, B, r, x=x, xi=xi, taken=0.6))
    bank = p.experts
    assert float(out["td_error"][0]) == pytest.approx(delta, abs=1e-6)
    assert float(bank.utilities[0, e, 0]) == pytest.approx(u_new, abs=1e-6)
    assert float(bank.means[0, e, 0]) == pytest.approx(mu_new, abs=1e-6)
    if delta > 0:  # c += kappa (x - c): a gradient step on 1/2 ||x - c||^2 with lr kappa
        c = c_before.clone().requires_grad_(True)
        (0.5 * (x - c).square().sum()).backward()
        expected = c_before - u.kappa * c.grad
        assert torch.allclose(bank.centres[0, e, 0], expected, atol=1e-6)
        assert not torch.equal(bank.centres[0, e, 0], c_before)
    else:
        assert torch.equal(bank.centres[0, e, 0], c_before)
    # nothing else moves: the next state's neuron, the actions, the count
    assert float(bank.utilities[0, e, 1]) == -0.5 and float(bank.actions[0, e, 0]) == 0.2
    assert int(out["grown"][0]) == 0 and int(out["neurons"][0]) == 2
    # the action taken is remembered for action replacement
    assert float(bank.taken[0, e, 0]) == pytest.approx(0.6) and bool(bank.used[0, e, 0])
    assert not bool(bank.used[0, e, 1])


@settings(max_examples=30, deadline=None)
@given(
    u_prev=st.floats(-15.0, 0.0),
    u_next=st.floats(-15.0, 0.0),
    mu=st.floats(-0.5, 0.5),
    r=st.floats(-4.0, 0.0),
    xi=st.floats(-1.0, 1.0),
    sigma=st.floats(0.01, 1.0),
)
def test_update_matches_autograd_everywhere(u_prev, u_next, mu, r, xi, sigma):
    p = _two_neurons(u_prev=u_prev, u_next=u_next, mu=mu)
    u = config_of(p).update
    u_new, mu_new, delta = _oracle(u_prev, u_next, mu, sigma, xi, r, u.gamma, u.eta, u.beta)
    out = teseo(p)(transition(p, A, B, r, xi=xi))
    bank, e = p.experts, _room(p)
    assert float(out["td_error"][0]) == pytest.approx(delta, abs=1e-5)
    if abs(delta) > u.error_threshold:  # error-driven growth instead of adaptation
        assert int(bank.count[0, e]) == 3 and int(out["grown"][0]) == 1
        assert float(bank.utilities[0, e, 0]) == u_prev and float(bank.means[0, e, 0]) == mu
        assert float(bank.utilities[0, e, 2]) == pytest.approx(u_prev + delta, abs=1e-5)
    else:
        assert int(bank.count[0, e]) == 2
        assert float(bank.utilities[0, e, 0]) == pytest.approx(u_new, abs=1e-5)
        assert float(bank.means[0, e, 0]) == pytest.approx(mu_new, abs=1e-5)


def test_error_driven_growth_instead_of_adaptation():
    p = _two_neurons()
    x = p.perceive(A["sonar"], A["odometry"], A["goal"]).x[0] + 0.05
    out = teseo(p)(transition(p, A, B, -3.5, x=x, proto=0.7, xi=0.3))
    delta = -3.5 + 0.95 * -0.5 + 1.0
    bank, e = p.experts, _room(p)
    assert float(out["td_error"][0]) == pytest.approx(delta)
    assert abs(delta) > config_of(p).update.error_threshold and int(out["grown"][0]) == 1
    assert int(bank.count[0, e]) == 3
    assert torch.equal(bank.centres[0, e, 2], x)  # a neuron at the previous input
    assert float(bank.utilities[0, e, 2]) == pytest.approx(-1.0 + delta)
    assert float(bank.actions[0, e, 2]) == pytest.approx(0.7) and float(bank.means[0, e, 2]) == 0
    # the winner is left as it was
    assert float(bank.utilities[0, e, 0]) == -1.0 and float(bank.means[0, e, 0]) == 0.1
    assert not torch.equal(bank.centres[0, e, 0], x)


def test_error_threshold_is_configurable():
    p = _two_neurons("update.error_threshold=5.0")
    teseo(p)(transition(p, A, B, -3.5))
    assert int(p.experts.count[0, _room(p)]) == 2  # |delta| = 2.975 < 5: adaptation


def test_terminated_next_state_is_worth_zero():
    p = _two_neurons()
    out = teseo(p)(transition(p, A, B, -0.3, terminated=True))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 1.0)
    p = _two_neurons()  # terminated wins over truncated (the goal reached at the last action)
    out = teseo(p)(transition(p, A, B, -0.3, terminated=True, truncated=True))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 1.0)


def test_novel_next_state_is_worth_its_reward():
    p = _two_neurons()
    out = teseo(p)(transition(p, A, FAR, -0.7))
    # u' = r: the utility the neuron grown there will get
    assert float(out["td_error"][0]) == pytest.approx(-0.7 + 0.95 * -0.7 + 1.0)
    assert int(p.experts.count[0, _room(p)]) == 2  # the policy grows it when it acts there


def test_next_state_in_another_region_bootstraps_from_that_expert():
    p = _two_neurons()
    door = observation(sonar=0.6, pose=POSES["door"])
    d = p.region_names.index("door")
    place(p, door, utility=-3.0)
    out = teseo(p)(transition(p, A, door, -0.3))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 0.95 * -3.0 + 1.0)
    assert int(p.experts.count[0, d]) == 1


def test_truncated_step_bootstraps_from_the_nearest_neuron():
    p = _two_neurons()
    out = teseo(p)(transition(p, A, B, -0.3, truncated=True))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 0.95 * -0.5 + 1.0)
    # far from every neuron: still the nearest one (B's), not the reward, and nothing grows
    p = _two_neurons()
    out = teseo(p)(transition(p, A, FAR, -0.3, truncated=True))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 0.95 * -0.5 + 1.0)
    assert int(out["grown"][0]) == 0 and int(p.experts.count[0, _room(p)]) == 2
    # an empty expert there: the previous winner's own utility
    p = _two_neurons()
    empty = observation(sonar=0.6, pose=POSES["door"])
    out = teseo(p)(transition(p, A, empty, -0.3, truncated=True))
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 0.95 * -1.0 + 1.0)


def test_novel_state_neuron_is_grown_at_the_start_of_the_update():
    p = _two_neurons()
    now = observation(sonar=0.9, state_reward=-0.7)
    x = p.perceive(now["sonar"], now["odometry"], now["goal"]).x[0]
    out = teseo(p)(transition(p, now, B, -0.4, novel=True, proto=0.45, xi=0.1, taken=0.55))
    bank, e = p.experts, _room(p)
    assert int(out["grown"][0]) == 1 and int(bank.count[0, e]) == 3
    delta = -0.4 + 0.95 * -0.5 - (-0.7)  # u of the new neuron = state_reward
    assert float(out["td_error"][0]) == pytest.approx(delta, abs=1e-6)
    assert torch.equal(bank.centres[0, e, 2], x)  # delta > 0 moves it toward x = its centre
    assert float(bank.actions[0, e, 2]) == pytest.approx(0.45)  # p = proto
    assert float(bank.utilities[0, e, 2]) == pytest.approx(-0.7 + 0.3 * delta, abs=1e-6)
    assert float(bank.means[0, e, 2]) == pytest.approx(0.2 * delta * 0.1, abs=1e-6)
    assert float(bank.taken[0, e, 2]) == pytest.approx(0.55) and bool(bank.used[0, e, 2])


def test_first_transition_into_an_empty_bank():
    p = policy("paper_literal")
    now = observation(sonar=0.3, state_reward=-0.2)
    out = teseo(p)(transition(p, now, B, -0.3, novel=True, proto=0.1))
    # the new neuron is the only one: the next state (novel) is worth its reward
    assert int(p.experts.count.sum()) == 1
    assert float(out["td_error"][0]) == pytest.approx(-0.3 + 0.95 * -0.3 + 0.2, abs=1e-6)


def test_set_keys_renames_what_the_update_reads():
    p = _two_neurons()
    update = teseo(p)
    update.set_keys(xi="noise", reward="r2", x="features")
    assert "noise" in update.in_keys and ("next", "r2") in update.in_keys
    assert "xi" not in update.in_keys and ("next", "reward") not in update.in_keys
    assert ("next", "features") in update.in_keys and ("next", "x") not in update.in_keys
    td = transition(p, A, B, -0.4, xi=0.35)
    td.rename_key_("xi", "noise")
    td.rename_key_(("next", "reward"), ("next", "r2"))
    td.rename_key_("x", "features")  # the perception's key, on the root and on next
    td.rename_key_(("next", "x"), ("next", "features"))
    update(td)
    u = config_of(p).update
    u_new, mu_new, _ = _oracle(-1.0, -0.5, 0.1, 0.2, 0.35, -0.4, u.gamma, u.eta, u.beta)
    e = _room(p)
    assert float(p.experts.means[0, e, 0]) == pytest.approx(mu_new, abs=1e-6)
    assert float(p.experts.utilities[0, e, 0]) == pytest.approx(u_new, abs=1e-6)
    with pytest.raises(ValueError, match="not an accepted"):
        update.set_keys(bogus="x")


@pytest.mark.parametrize("key", ["xi", ("next", "reward"), "taken"])
def test_a_missing_key_is_a_key_error_naming_it(key):
    p = _two_neurons()
    td = transition(p, A, B, -0.4)
    del td[key]
    with pytest.raises(KeyError, match=key if isinstance(key, str) else key[1]):
        teseo(p)(td)


def test_a_batch_updates_each_robot_as_alone():
    def robot(seed_u: float, reward: float, b: int, p=None):
        if p is None:
            p = policy("paper_literal", seeds=(0, 1))
        place(p, A, action=0.2, utility=seed_u, mean=0.1, row=b)
        place(p, B, utility=-0.5, row=b)
        return p

    p = robot(-1.0, 0.0, 0)
    robot(-2.0, 0.0, 1, p)
    t0 = transition(p, A, B, -0.4, xi=0.3)
    t1 = transition(p, A, B, -3.9, xi=-0.2, row=1)  # robot 1: error-driven growth
    batch = torch.cat([t0, t1], 0)
    out = teseo(p)(batch)
    alone = []
    for u0, t in ((-1.0, t0), (-2.0, t1)):
        q = policy("paper_literal")
        place(q, A, action=0.2, utility=u0, mean=0.1)
        place(q, B, utility=-0.5)
        alone.append((q, teseo(q)(t.clone())))
    assert out["grown"].tolist() == [0, 1]
    for b, (q, o) in enumerate(alone):
        assert float(out["td_error"][b]) == float(o["td_error"][0])
        n = int(q.experts.count.sum())
        for name in ("centres", "actions", "utilities", "means", "taken", "used"):
            got = getattr(p.experts, name)[b, :, :n]
            assert torch.equal(got, getattr(q.experts, name)[0, :, :n]), name


def test_no_learning_changes_nothing():
    p = policy("reflex_only")
    out = teseo(p)(transition(p, A, B, -0.4, novel=True))
    assert int(p.experts.count.sum()) == 0
    assert out["td_error"].tolist() == [0.0] and out["grown"].tolist() == [0]


# -- end of trial ---------------------------------------------------------------------------


def _step(update, taken: float) -> None:
    """Neuron 0 acts (taken) on a transition A -> B with a small TD error."""
    update(transition(update.policy, A, B, -0.5, taken=taken))


def test_action_replacement_only_after_a_better_successful_trial():
    p = _two_neurons()
    update = teseo(p)
    bank, e, row = p.experts, _room(p), torch.tensor([0])
    _step(update, taken=-0.7)
    out = update.end_trial(row, torch.tensor([-5.0]), torch.tensor([False]))  # failed: nothing
    assert out["replaced"].tolist() == [0] and not bool(out["improved"][0])
    assert float(bank.actions[0, e, 0]) == 0.2 and float(p.progress.best_total[0]) == -math.inf
    assert not bank.used.any()  # the trial's bookkeeping is cleared
    _step(update, taken=-0.7)
    mean_before = float(bank.means[0, e, 0])
    assert mean_before != 0.0
    out = update.end_trial(row, torch.tensor([-10.0]), torch.tensor([True]))
    assert out["replaced"].tolist() == [1] and bool(out["improved"][0])
    assert float(bank.actions[0, e, 0]) == pytest.approx(-0.7) and float(bank.means[0, e, 0]) == 0
    assert float(bank.actions[0, e, 1]) == -0.2  # not used in this trial
    assert float(p.progress.best_total[0]) == -10.0 and float(out["best_total"][0]) == -10.0
    _step(update, taken=0.9)
    bank.means[0, e, 0] = 0.3
    out = update.end_trial(row, torch.tensor([-12.0]), torch.tensor([True]))  # worse
    assert out["replaced"].tolist() == [0] and not bool(out["improved"][0])
    assert float(bank.actions[0, e, 0]) == pytest.approx(-0.7)
    assert float(bank.means[0, e, 0]) == 0.3 and float(p.progress.best_total[0]) == -10.0
    _step(update, taken=0.9)
    out = update.end_trial(row, torch.tensor([-8.0]), torch.tensor([True]))  # better again
    assert out["replaced"].tolist() == [1] and float(bank.actions[0, e, 0]) == pytest.approx(0.9)


def test_no_replacement_when_switched_off_but_the_best_total_is_kept():
    p = _two_neurons("update.replace_actions=false")
    update = teseo(p)
    _step(update, taken=-0.7)
    out = update.end_trial(torch.tensor([0]), torch.tensor([-10.0]), torch.tensor([True]))
    assert out["replaced"].tolist() == [0] and bool(out["improved"][0])
    assert float(p.experts.actions[0, _room(p), 0]) == 0.2
    assert float(p.progress.best_total[0]) == -10.0


def test_end_trial_touches_only_the_robots_given():
    p = policy("paper_literal", seeds=(0, 1))
    for b in (0, 1):
        place(p, A, action=0.2, utility=-1.0, row=b)
        place(p, B, utility=-0.5, row=b)
    update = teseo(p)
    update(torch.cat([transition(p, A, B, -0.5, taken=-0.7, row=b) for b in (0, 1)], 0))
    out = update.end_trial(torch.tensor([1]), torch.tensor([-4.0]), torch.tensor([True]))
    e = _room(p)
    assert isinstance(out, TensorDictBase) and out.batch_size == torch.Size([1])
    assert out["replaced"].tolist() == [1]
    assert float(p.experts.actions[1, e, 0]) == pytest.approx(-0.7)
    assert float(p.experts.actions[0, e, 0]) == 0.2 and bool(p.experts.used[0, e, 0])
    assert p.progress.temperature.tolist() == pytest.approx([0.3, 0.3 * 0.85])
    assert p.progress.best_total.tolist() == [-math.inf, -4.0]
    assert p.progress.trials_done.tolist() == [0, 1]


def test_cooling_down_to_the_floor():
    p = policy(
        "paper_literal",
        "update.temperature0=0.3",
        "update.cooling=0.5",
        "update.temperature_min=0.05",
    )
    update = teseo(p)
    temps = []
    for k in range(6):  # failed and successful trials cool alike
        update.end_trial(torch.tensor([0]), torch.tensor([-50.0]), torch.tensor([k % 2 == 0]))
        temps.append(float(p.progress.temperature[0]))
    assert temps == pytest.approx([0.15, 0.075, 0.05, 0.05, 0.05, 0.05])
    paper = policy("paper_map", seeds=(3,))
    update = teseo(paper)
    for _ in range(40):
        update.end_trial(torch.tensor([0]), torch.tensor([-50.0]), torch.tensor([False]))
    assert float(paper.progress.temperature[0]) == pytest.approx(0.1 * 0.85**40)  # floor 0


def _option_policy(*overrides: str):
    """Options on, greedy choices (untried ones are not tried first): the first option of a
    region until another one has a better critic."""
    return policy(
        "paper_map", "option_critic.try_untried=false", "option_critic.epsilon=0", *overrides
    )


def _act(p, update, obs, nxt, reward):
    """The policy acts on ``obs``; the update learns from the transition to ``nxt``."""
    td = act(p, obs.clone())
    td["next"] = transition(p, obs, nxt, reward)["next"]
    update(td)
    return td


@pytest.mark.parametrize(
    "critic, expected", [("mean", [-3.0, -2.0, -3.0]), ("best", [-3.0, -1.0, -1.0])]
)
def test_option_critic_steps_toward_the_return_to_go(critic, expected):
    p = _option_policy(f"option_critic.critic={critic}")
    update = teseo(p)
    room = _room(p)
    rows = torch.tensor([0])
    got = []
    for rewards in ([-1.0, -2.0], [-1.0], [-3.0, -2.0]):
        p.begin_trial(rows)
        for k, r in enumerate(rewards):
            td = _act(p, update, A, B, r)
            assert bool(td["option_entry"][0]) == (k == 0)
        option = int(td["option"][0])
        update.end_trial(rows, torch.tensor([sum(rewards)]), torch.tensor([True]))
        got.append(float(p.options.critic.q[0, room, option]))
    assert option == 0 and got == pytest.approx(expected)
    assert int(p.options.critic.n[0, room, 0]) == 3 and int(p.options.critic.n[0, room].sum()) == 3
    assert float(p.options.critic.epsilon[0]) == 0.0 and int(p.options.critic.trials[0]) == 3


def test_option_return_to_go_starts_at_each_regions_first_entry():
    p = _option_policy()
    update = teseo(p)
    door_obs = observation(sonar=0.6, pose=POSES["door"])
    room, door = _room(p), p.region_names.index("door")
    _act(p, update, A, B, -1.0)
    _act(p, update, door_obs, door_obs, -2.0)
    _act(p, update, door_obs, door_obs, -0.5)
    update.end_trial(torch.tensor([0]), torch.tensor([-3.5]), torch.tensor([False]))
    assert float(p.options.critic.q[0, room, 0]) == pytest.approx(-3.5)
    assert float(p.options.critic.q[0, door, 0]) == pytest.approx(-2.5)
    assert int(p.options.critic.n[0].sum()) == 2  # the regions not entered learn nothing
    assert float(update.returns.trial_return[0]) == 0.0 and not update.returns.entry_return.any()


def test_the_critic_learns_the_shortest_trial_that_reached_the_goal():
    p = policy("paper_map", "option_critic.try_if_shorter=true")
    update = teseo(p)
    rows, critic = torch.tensor([0]), p.options.critic
    for actions, reached in ((3, False), (4, True), (2, True), (3, True)):
        p.begin_trial(rows)
        for _ in range(actions):
            _act(p, update, A, B, -1.0)
        update.end_trial(rows, torch.tensor([-float(actions)]), torch.tensor([reached]))
    assert critic.shortest_trial(0) == 2.0


def test_end_trial_reports_the_temperature_the_trial_explored_with():
    p = policy("paper_literal", "update.temperature0=0.3", "update.cooling=0.5")
    update = teseo(p)
    out = update.end_trial(torch.tensor([0]), torch.tensor([-50.0]), torch.tensor([False]))
    assert out["temperature"].tolist() == [0.3]  # the trial's, before the cooling at its end
    assert float(p.progress.temperature[0]) == 0.15


def test_the_update_is_a_plain_object_whose_state_is_the_trials_returns():
    from torch import nn

    from symrl.learner.loss import TeseoLoss

    p = _option_policy()
    cfg = config_of(p)
    update = TeseoLoss(p, cfg.update, cfg.trial_gradient, cfg.env.robot, cfg.env.max_actions)
    assert TeseoLoss is TeseoUpdate  # the former name is the same class
    assert type(update) is TeseoUpdate and not isinstance(update, nn.Module)
    assert update.policy is p and update.experts is p.experts
    assert sorted(update.state_dict()) == ["entry_return", "trial_return"]
    _act(p, update, A, B, -1.0)
    fresh = teseo(p)
    fresh.load_state_dict(update.state_dict())
    assert torch.equal(fresh.returns.trial_return, update.returns.trial_return)
