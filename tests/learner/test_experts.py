"""Growing RBF expert: winner search, distance-driven growth, storage growth, state round trip."""

from __future__ import annotations

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.learner.experts import GrowingRBFExpert


def test_winner_is_the_nearest_centre():
    g = torch.Generator().manual_seed(0)
    e = GrowingRBFExpert(dim=32, capacity=8)
    centres = torch.rand(50, 32, generator=g)
    for c in centres:
        e.add(c, 0.0, 0.0)
    for _ in range(20):
        x = torch.rand(32, generator=g)
        d = (centres - x).norm(dim=1)
        i, dist = e.nearest(x)
        assert i == int(d.argmin())
        assert dist == pytest.approx(float(d.min()), abs=1e-5)
    near = centres[7] + 0.01
    assert int(torch.argmax(e.activations(near))) == 7  # argmax activation = argmin distance


def test_empty_expert_has_no_winner():
    e = GrowingRBFExpert()
    i, dist = e.nearest(torch.zeros(32))
    assert i == -1 and dist == float("inf") and e.is_novel(dist)


def test_distance_driven_growth_threshold():
    e = GrowingRBFExpert(novelty_radius=0.1)
    e.add(torch.zeros(32), 0.0, 0.0)
    near = torch.zeros(32)
    near[0] = 0.09
    far = torch.zeros(32)
    far[0] = 0.11
    assert not e.is_novel(e.nearest(near)[1])
    assert e.is_novel(e.nearest(far)[1])


def test_storage_doubles_and_state_dict_round_trips_sizes():
    e = GrowingRBFExpert(capacity=2, name="room")
    for k in range(5):
        e.add(torch.full((32,), float(k)), action=0.1 * k, utility=-k, mean=0.01 * k)
    assert len(e) == 5 and e.capacity == 8
    fresh = GrowingRBFExpert(capacity=2, name="room")
    fresh.load_state_dict(e.state_dict())
    assert len(fresh) == 5
    assert torch.equal(fresh.centres[:5], e.centres[:5])
    assert fresh.rows.utilities[4] == -4.0 and fresh.rows.actions[3] == pytest.approx(0.3)
    x = torch.full((32,), 3.2)
    assert fresh.nearest(x) == e.nearest(x)


def test_max_neurons_is_a_clear_error():
    e = GrowingRBFExpert(capacity=2, max_neurons=3, name="door")
    for _ in range(3):
        e.add(torch.zeros(32), 0.0, 0.0)
    with pytest.raises(RuntimeError, match="door.*max_neurons=3"):
        e.add(torch.zeros(32), 0.0, 0.0)


def test_shift_centre_keeps_the_search_exact():
    e = GrowingRBFExpert()
    e.add(torch.zeros(32), 0.0, 0.0)
    e.add(torch.ones(32), 0.0, 0.0)
    e.shift_centre(0, torch.full((32,), 0.8), 1.0)  # neuron 0 moves next to neuron 1
    i, dist = e.nearest(torch.full((32,), 0.79))
    assert i == 0 and dist == pytest.approx(0.01 * 32**0.5, rel=1e-4)


def test_replace_actions_only_touches_used_neurons():
    e = GrowingRBFExpert()
    for k in range(3):
        e.add(torch.full((32,), float(k)), action=1.0, utility=0.0, mean=0.5)
    e.rows.taken[1] = -0.7
    e.rows.used[1] = True
    assert e.replace_actions() == 1
    assert e.rows.actions.tolist()[:3] == pytest.approx([1.0, -0.7, 1.0])
    assert e.rows.means.tolist()[:3] == pytest.approx([0.5, 0.0, 0.5])
    e.clear_trial()
    assert not e.used.any()


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 300),
    seed=st.integers(0, 10_000),
    scale=st.floats(0.01, 3.0),
)
def test_winner_search_matches_brute_force(n, seed, scale):
    g = torch.Generator().manual_seed(seed)
    centres = torch.rand(n, 32, generator=g) * scale
    e = GrowingRBFExpert(capacity=4)
    for c in centres:
        e.add(c, 0.0, 0.0)
    x = torch.rand(32, generator=g) * scale
    d = (centres - x).norm(dim=1)
    i, dist = e.nearest(x)
    # the fused search may pick a different index only on a numerical tie
    assert float(d[i]) == pytest.approx(float(d.min()), abs=1e-4 * (1 + scale))
    assert dist == pytest.approx(float(d[i]), abs=1e-5)
