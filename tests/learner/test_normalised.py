"""The pose input and the normalised RBF activations (``experts.input: pose``,
``experts.activation: normalised``): the encoding, the weights, the update against autograd, and
growth that starts from the network's estimates."""

from __future__ import annotations

import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from learner_helpers import observation, place, policy, transition
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.learner.experts import ExpertBank
from symrl.learner.loss import TeseoLoss

SOFT = ("experts.input=pose", "experts.activation=normalised", "experts.width=0.4",
        "experts.novelty_radius=0.5", "experts.heading_scale=1")  # fmt: skip
A = observation(pose=(0.0, 0.0, 0.0))
B = observation(pose=(0.3, 0.0, 0.0))
NEXT = observation(pose=(0.2, 0.1, 0.5))


def test_pose_input_is_the_odometry_pose_with_a_heading_scale():
    p = policy("paper_literal", "experts.input=pose", "experts.heading_scale=0.5")
    obs = observation(pose=(1.0, -2.0, math.pi / 2))
    x = p.perceive(obs["sonar"], obs["odometry"], obs["goal"]).x[0]
    assert p.input_dim == 4
    assert torch.allclose(x, torch.tensor([1.0, -2.0, 0.0, 0.5]), atol=1e-6)


def test_weights_are_normalised_gaussians_and_one_hot_as_the_width_shrinks():
    bank = ExpertBank(batch=2, experts=2, dim=1)
    for c in (0.0, 1.0, 3.0):
        bank.add(torch.tensor([0]), torch.tensor([1]), torch.tensor([[c]]),
                 torch.zeros(1), torch.zeros(1))  # fmt: skip
    x = torch.tensor([[0.4], [0.4]])
    w = bank.weights(torch.tensor([1, 1]), x, width=1.0)
    phi = torch.exp(-(torch.tensor([0.4, 0.6, 2.6], dtype=torch.float64) ** 2))
    assert torch.allclose(w[0], phi / phi.sum())
    assert w[1].tolist() == [0.0, 0.0, 0.0]  # robot 1's expert is empty
    sharp = bank.weights(torch.tensor([1, 1]), x, width=0.01)
    assert sharp[0].tolist() == [1.0, 0.0, 0.0]  # the winner alone: the paper's rule


@settings(max_examples=40, deadline=None)
@given(
    centres=st.lists(st.floats(-2, 2, allow_nan=False), min_size=1, max_size=6),
    query=st.floats(-2, 2, allow_nan=False),
    width=st.floats(0.05, 2.0),
)
def test_weights_sum_to_one_and_read_is_the_weighted_mean(centres, query, width):
    bank = ExpertBank(batch=1, experts=1, dim=1, capacity=2)
    for i, c in enumerate(centres):
        bank.add(torch.tensor([0]), torch.tensor([0]), torch.tensor([[c]]),
                 torch.tensor([float(i)]), torch.tensor([-float(i)]))  # fmt: skip
    w = bank.weights(torch.tensor([0]), torch.tensor([[query]]), width)
    assert float(w.sum()) == pytest.approx(1.0)
    values = torch.arange(len(centres), dtype=torch.float64)
    assert float(bank.read("actions", torch.tensor([0]), w)) == pytest.approx(
        float((w[0] * values).sum())
    )


def _soft_two_neurons():
    p = policy("paper", *SOFT)
    assert place(p, A, action=0.0, utility=-1.0, mean=0.1) == 0
    assert place(p, B, action=0.0, utility=-2.0, mean=-0.3) == 1
    return p


def test_normalised_update_matches_autograd():
    p = _soft_two_neurons()
    e = p.region_names.index("room")
    bank = p.experts
    x = p.perceive(A["sonar"], A["odometry"], A["goal"]).x
    nx = p.perceive(NEXT["sonar"], NEXT["odometry"], NEXT["goal"]).x
    width, u = p.config.experts.width, p.config.update
    centres = bank.centres[0, e, :2].double()
    utilities = bank.utilities[0, e, :2].clone().requires_grad_(True)
    means = bank.means[0, e, :2].clone().requires_grad_(True)

    def w(at):
        return torch.softmax(-((centres - at.double()) ** 2).sum(-1) / width**2, 0)

    r, xi, sigma = -0.3, 0.25, 0.1
    v = (w(x) * utilities).sum()
    target = r + u.gamma * (w(nx) * utilities).sum().detach()
    delta = target - v
    (0.5 * delta**2).backward()
    m = (w(x) * means).sum()
    normal = torch.distributions.Normal(m, torch.tensor(sigma, dtype=torch.float64))
    (-delta.detach() * normal.log_prob(torch.tensor(xi, dtype=torch.float64))).backward()
    expected_u = utilities.detach() - u.eta * utilities.grad
    expected_mu = means.detach() - u.beta * sigma**2 * means.grad

    out = TeseoLoss(p)(transition(p, A, NEXT, r, xi=xi))
    assert float(out["td_error"][0]) == pytest.approx(float(delta.detach()), abs=1e-6)
    assert torch.allclose(bank.utilities[0, e, :2], expected_u, atol=1e-6)
    assert torch.allclose(bank.means[0, e, :2], expected_mu, atol=1e-6)
    assert int(bank.count[0, e]) == 2  # nothing grew


def test_a_neuron_grown_at_a_novel_state_starts_from_the_network_there():
    p = _soft_two_neurons()
    e = p.region_names.index("room")
    far = observation(pose=(0.0, 1.2, 0.0))  # beyond the novelty radius of both neurons
    x = p.perceive(far["sonar"], far["odometry"], far["goal"]).x
    w = p.experts.weights(torch.tensor([e]), x, p.config.experts.width)
    v_before = float(p.experts.read("utilities", torch.tensor([e]), w))
    mu_before = float(p.experts.read("means", torch.tensor([e]), w))
    out = TeseoLoss(p)(
        transition(
            p, far, far, -0.2, novel=True, xi=mu_before, taken=mu_before, proto=0.0, terminated=True
        )  # fmt: skip
    )
    bank = p.experts
    assert int(out["grown"][0]) == 1 and int(bank.count[0, e]) == 3
    assert float(bank.means[0, e, 2]) == pytest.approx(mu_before)
    # born with u = V(x); xi == mu gives no actor step; the TD step moved the three neurons
    delta = -0.2 - v_before
    assert float(out["td_error"][0]) == pytest.approx(delta, abs=1e-6)
    w = bank.weights(torch.tensor([e]), x, p.config.experts.width)
    assert float(bank.read("means", torch.tensor([e]), w)) == pytest.approx(mu_before, abs=1e-9)


def test_normalised_policy_acts_with_the_weighted_estimates():
    p = _soft_two_neurons()
    e = torch.tensor([p.region_names.index("room")])
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        td = p(observation(pose=(0.15, 0.0, 0.0)))
    x = td["x"]
    w = p.experts.weights(e, x, p.config.experts.width)
    assert torch.allclose(w, torch.tensor([[0.5, 0.5]], dtype=torch.float64))  # midway
    assert float(td["xi"][0]) == pytest.approx(-0.1)  # the mean of 0.1 and -0.3
    assert not bool(td["shielded"][0])
    assert float(td["taken"][0]) == pytest.approx(-0.1)  # the correction on the reflex
