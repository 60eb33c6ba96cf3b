"""ExpertBank: winner search per controller, growth, storage doubling, end-of-trial writes,
state round trip, and independence of the controllers of a batch."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.learner.experts import ExpertBank, _sum_last

D = 4


def _add(bank: ExpertBank, row: int, expert: int, centre, action=0.0, utility=0.0) -> int:
    index = bank.add(
        torch.tensor([row]),
        torch.tensor([expert]),
        torch.tensor([centre], dtype=torch.float32),
        torch.tensor([action]),
        torch.tensor([utility]),
    )
    return int(index[0])


def test_nearest_at_known_centres_and_empty_experts():
    bank = ExpertBank(batch=2, experts=3, dim=D, capacity=4)
    _add(bank, 0, 1, [0.0, 0.0, 0.0, 0.0])
    _add(bank, 0, 1, [1.0, 0.0, 0.0, 0.0])
    _add(bank, 0, 1, [0.0, 2.0, 0.0, 0.0])
    _add(bank, 1, 0, [5.0, 5.0, 5.0, 5.0])
    x = torch.tensor([[0.9, 0.1, 0.0, 0.0], [5.0, 5.0, 5.0, 5.5]])
    winner, dist = bank.nearest(torch.tensor([1, 0]), x)
    assert winner.tolist() == [1, 0]
    assert dist.tolist() == pytest.approx([math.hypot(0.1, 0.1), 0.5], abs=1e-6)
    # controller 1's expert 1 and controller 0's expert 0 are empty
    winner, dist = bank.nearest(torch.tensor([0, 1]), x)
    assert winner.tolist() == [-1, -1] and dist.tolist() == [math.inf, math.inf]
    # one empty, one not
    winner, dist = bank.nearest(torch.tensor([1, 1]), x)
    assert winner.tolist() == [1, -1] and math.isinf(float(dist[1]))
    # an input right on a centre
    on = torch.tensor([[0.0, 2.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    winner, dist = bank.nearest(torch.tensor([1, 2]), on)
    assert winner.tolist() == [2, -1] and float(dist[0]) == 0.0


def test_add_returns_indices_and_writes_fresh_rows():
    bank = ExpertBank(batch=3, experts=2, dim=D, capacity=8)
    _add(bank, 2, 1, [1.0] * D)
    index = bank.add(
        torch.tensor([0, 2]),
        torch.tensor([1, 1]),
        torch.tensor([[0.5] * D, [0.25] * D]),
        torch.tensor([0.3, -0.3]),
        torch.tensor([-1.0, -2.0]),
    )
    assert index.tolist() == [0, 1]
    assert bank.neurons().tolist() == [[0, 1], [0, 0], [0, 2]]
    assert bank.actions[2, 1, 1] == pytest.approx(-0.3) and bank.utilities[0, 1, 0] == -1.0
    assert torch.equal(bank.centres[2, 1, 1], torch.full((D,), 0.25))
    assert bank.means[2, 1, 1] == 0.0 and not bool(bank.used[2, 1, 1])
    assert bank.actions.dtype == bank.utilities.dtype == torch.float64
    empty = bank.add(
        torch.tensor([], dtype=torch.long),
        torch.tensor([], dtype=torch.long),
        torch.zeros(0, D),
        torch.zeros(0),
        torch.zeros(0),
    )
    assert empty.numel() == 0 and bank.neurons().sum() == 3


def test_storage_doubles_and_keeps_the_contents():
    bank = ExpertBank(batch=2, experts=2, dim=D, capacity=2)
    for k in range(5):
        assert _add(bank, 1, 0, [float(k)] * D, action=0.1 * k, utility=-k) == k
    _add(bank, 0, 1, [9.0] * D, action=0.9)
    assert bank.capacity == 8  # 2 -> 4 -> 8
    assert bank.centres.shape == (2, 2, 8, D) and bank.used.shape == (2, 2, 8)
    assert bank.neurons().tolist() == [[0, 1], [5, 0]]
    assert bank.actions[1, 0, :5].tolist() == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert bank.utilities[1, 0, :5].tolist() == [0.0, -1.0, -2.0, -3.0, -4.0]
    assert bank.actions[0, 1, 0] == pytest.approx(0.9)
    winner, _ = bank.nearest(torch.tensor([0, 0]), torch.tensor([[0.0] * D, [3.1] * D]))
    assert winner.tolist() == [-1, 3]
    assert dict(bank.named_buffers())["centres"] is bank.centres  # still a registered buffer


def test_max_neurons_is_a_clear_error():
    bank = ExpertBank(batch=1, experts=2, dim=D, capacity=2, max_neurons=3, names=("room", "door"))
    for k in range(3):
        _add(bank, 0, 1, [float(k)] * D)
    assert bank.capacity == 3  # doubling stops at the limit
    with pytest.raises(RuntimeError, match=r"'door'.*max_neurons=3"):
        _add(bank, 0, 1, [5.0] * D)
    assert bank.neurons().tolist() == [[0, 3]]


def test_replace_actions_only_on_used_neurons_of_the_rows_given():
    bank = ExpertBank(batch=2, experts=2, dim=D, capacity=4)
    for row in (0, 1):
        for k in range(3):
            _add(bank, row, 0, [float(k)] * D, action=1.0)
    bank.means.fill_(0.5)
    bank.taken.fill_(-0.7)
    bank.used[0, 0, 1] = bank.used[1, 0, 2] = True
    replaced = bank.replace_actions(torch.tensor([0]))
    assert replaced.tolist() == [1]
    assert bank.actions[0, 0, :3].tolist() == pytest.approx([1.0, -0.7, 1.0])
    assert bank.means[0, 0, :3].tolist() == pytest.approx([0.5, 0.0, 0.5])
    assert bank.actions[1, 0, :3].tolist() == [1.0, 1.0, 1.0]  # controller 1 not asked
    assert bank.means[1, 0, 2] == 0.5
    bank.clear_trial(torch.tensor([0]))
    assert not bank.used[0].any() and bool(bank.used[1, 0, 2])
    bank.clear_trial(torch.tensor([1]))
    assert not bank.used.any()


def test_state_dict_of_a_grown_bank_loads_into_a_fresh_one():
    bank = ExpertBank(batch=2, experts=2, dim=D, capacity=2, names=("a", "b"))
    for k in range(5):
        _add(bank, 0, 1, [0.5 * k] * D, action=0.1 * k, utility=-float(k))
    bank.means[0, 1, 3] = 0.25
    fresh = ExpertBank(batch=2, experts=2, dim=D, capacity=2, names=("a", "b"))
    fresh.load_state_dict(bank.state_dict())
    assert fresh.capacity == bank.capacity == 8
    for name, value in bank.state_dict().items():
        assert torch.equal(fresh.state_dict()[name], value), name
    x = torch.full((2, D), 1.1)
    assert [t.tolist() for t in fresh.nearest(torch.tensor([1, 1]), x)] == [
        t.tolist() for t in bank.nearest(torch.tensor([1, 1]), x)
    ]
    _add(fresh, 0, 1, [9.0] * D)  # and it keeps growing
    assert fresh.neurons().tolist() == [[0, 6], [0, 0]]


def test_bad_sizes_are_refused():
    with pytest.raises(ValueError, match="batch=0"):
        ExpertBank(batch=0, experts=1, dim=D)


_centres = st.lists(
    st.lists(st.floats(-2, 2, allow_nan=False, width=32), min_size=D, max_size=D),
    min_size=0,
    max_size=12,
)


@settings(max_examples=25, deadline=None)
@given(
    own=_centres,
    others=st.lists(_centres, min_size=1, max_size=4),
    query=st.lists(st.floats(-2, 2, allow_nan=False, width=32), min_size=D, max_size=D),
    position=st.integers(0, 4),
    capacity=st.integers(1, 6),
)
def test_a_controllers_winner_does_not_depend_on_the_others(own, others, query, position, capacity):
    """The winner (and distance) of controller b depend only on its own neurons, whatever the
    other controllers hold and however large the batch is."""

    def search(contents: list[list[list[float]]], b: int) -> tuple[int, float]:
        bank = ExpertBank(batch=len(contents), experts=2, dim=D, capacity=capacity)
        for row, centres in enumerate(contents):
            for c in centres:
                _add(bank, row, 1, c)
                _add(bank, row, 0, [v + 1.0 for v in c])  # the other expert is not searched
        x = torch.tensor([query] * len(contents))
        winner, dist = bank.nearest(torch.ones(len(contents), dtype=torch.long), x)
        return int(winner[b]), float(dist[b])

    alone = search([own], 0)
    position = min(position, len(others))
    batch = [*others[:position], own, *others[position:]]
    assert search(batch, position) == alone
    if own:  # the brute-force winner
        d = (torch.tensor(own) - torch.tensor(query)).square().sum(-1)
        assert float(d[alone[0]]) == float(d.min())
    else:
        assert alone == (-1, math.inf)


def test_a_copied_bank_writes_its_own_storage():
    import copy

    bank = ExpertBank(2, 2, 4)
    bank.flat.actions[0] = 1.0  # views cached
    other = copy.deepcopy(bank)
    other.flat.actions[1] = 2.0
    assert other.actions.view(-1)[:2].tolist() == [1.0, 2.0]
    assert bank.actions.view(-1)[:2].tolist() == [1.0, 0.0]


@pytest.mark.parametrize("shape", [(1, 1, 4), (10, 40, 4), (1000, 100, 4), (10, 7, 27)])
def test_the_distance_sum_is_torchs_bit_for_bit(shape):
    """The winner search's squared distances: four terms are added in numpy in torch's order;
    the sum is torch's own bits for any magnitudes."""
    rng = np.random.default_rng(sum(shape))
    d = rng.normal(size=shape) * 10.0 ** rng.uniform(-4, 4, size=shape)
    squares = np.square(d.astype(np.float32))
    want = torch.from_numpy(squares).sum(-1).numpy()
    assert np.array_equal(_sum_last(squares).view(np.int32), want.view(np.int32))
