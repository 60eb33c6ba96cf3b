"""BufferViews: the numpy views follow every way a buffer can be replaced."""

import numpy as np
import torch

from symrl.buffers import BufferViews


class _Module(BufferViews):
    def __init__(self) -> None:
        super().__init__()
        self.register_buffer("a", torch.zeros(3))


def test_views_share_memory_and_follow_in_place_writes():
    m = _Module()
    m.arrays["a"][1] = 2.0
    assert m.a.tolist() == [0.0, 2.0, 0.0]
    m.a[2] = 5.0
    assert m.arrays["a"].tolist() == [0.0, 2.0, 5.0]


def test_views_are_taken_again_after_a_buffer_is_replaced():
    m = _Module()
    first = m.arrays["a"]
    m.a = torch.ones(3)  # assigned
    assert m.arrays["a"].tolist() == [1.0, 1.0, 1.0] and m.arrays["a"] is not first
    m.load_state_dict({"a": torch.full((3,), 4.0)}, assign=True)
    assert m.arrays["a"].tolist() == [4.0] * 3
    m.load_state_dict({"a": torch.full((3,), 6.0)})  # copied in place
    assert m.arrays["a"].tolist() == [6.0] * 3
    m.double()
    assert m.arrays["a"].dtype == np.float64 and np.shares_memory(m.arrays["a"], m.a.numpy())
    m.register_buffer("b", torch.arange(2))
    assert m.arrays["b"].tolist() == [0, 1]


def test_a_copy_takes_views_of_its_own_buffers():
    import copy
    import pickle

    m = _Module()
    m.arrays["a"][0] = 1.0  # views cached
    for other in (copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        other.arrays["a"][1] = 3.0
        assert other.a.tolist() == [1.0, 3.0, 0.0] and m.a.tolist() == [1.0, 0.0, 0.0]
