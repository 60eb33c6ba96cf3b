"""The loop's TensorDict accessors behave as TensorDict's public get/update."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict

from symrl.tensordicts import read, write


def _td() -> TensorDict:
    return TensorDict({"a": torch.zeros(3, 2), "next": {"r": torch.ones(3, 1)}}, batch_size=[3])


def test_read_is_getitem():
    td = _td()
    assert read(td, "a") is td["a"]
    assert read(td, ("next", "r")) is td["next", "r"]
    with pytest.raises(KeyError, match="missing"):
        read(td, "missing")


def test_write_is_update():
    values = {"a": torch.full((3, 2), 2.0), "b": torch.arange(3), ("next", "r"): torch.zeros(3, 1)}
    fast, checked = write(_td(), values), _td().update(values)
    assert set(fast.keys(True, True)) == set(checked.keys(True, True))
    assert (fast == checked).all()


def test_write_keeps_the_checks_where_they_matter():
    with pytest.raises(RuntimeError):  # a batch-size mismatch is still refused
        write(_td(), {"c": torch.zeros(4)})
    locked = _td().lock_()
    with pytest.raises(RuntimeError):
        write(locked, {"c": torch.zeros(3)})
