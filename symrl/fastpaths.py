"""Every shortcut past TorchRL's, TensorDict's and TensorBoard's checked public calls, in one
place: nothing else in symrl touches their private attributes (``tests/test_fastpaths.py`` pins
each function to the public call it stands for, and that no other module reaches past them).

Why they exist: the control loop steps a handful of robots, where a public call's checks cost
more than the work (TensorDict's ``get``/``set`` about 1.5 us per read and 10 us per written
key on the shared 2-core VM; TorchRL's generic step, ``step_mdp`` and partial reset half the
loop at B = 10), measured with ``benchmarks/bench_train.py``. The shortcuts are the unchecked
accessors the libraries' own hot paths use, taken only where the loop built the inputs itself
(plain string keys, shapes of the batch, CPU), so the results are the public calls' own.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.utils import NestedKey

__all__ = [
    "file_writer",
    "new_tensordict",
    "read",
    "tensordict_items",
    "transform_reset",
    "transform_step",
    "write",
]

_MISSING = object()


def read(td: TensorDictBase, key: NestedKey, default: Any = _MISSING) -> Any:
    """``td[key]`` (a KeyError naming the key when it is missing), or ``td.get(key, default)``
    when a default is given. A plain TensorDict's string key is read from its entries dict
    (``_get_str``'s), about a fifth of ``td[key]``'s cost (``benchmarks/bench_train.py``: the
    loop reads ~60 entries a step); any other TensorDict or key takes the public path."""
    if type(td) is TensorDict and type(key) is str:
        value = td._tensordict.get(key, _MISSING)
        if value is not _MISSING:
            return value
    return td[key] if default is _MISSING else td.get(key, default)


def write(td: TensorDictBase, values: Mapping[str, torch.Tensor]) -> TensorDictBase:
    """``td.update(values)`` for tensors (or plain TensorDicts) whose leading dims are ``td``'s
    batch size: into a plain, unlocked TensorDict's entries dict as
    ``_set_str(validated=True, inplace=False)`` assigns, the shape checked here once per value
    (a tenth of ``update``'s cost per key, ``benchmarks/bench_train.py``). Anything else (a
    nested key, a wrong shape, a locked TensorDict) takes ``update`` and its errors."""
    if type(td) is not TensorDict or td.is_locked:
        return td.update(values)
    batch = td.batch_size
    dims = len(batch)
    entries = td._tensordict
    for key, value in values.items():
        if (
            type(key) is not str
            or type(value) not in (torch.Tensor, TensorDict)
            or value.shape[:dims] != batch
        ):
            td.update({key: value})  # the checked path (and its error message)
        else:
            entries[key] = value
    return td


def tensordict_items(td: TensorDictBase, batch: torch.Size) -> dict[str, torch.Tensor] | None:
    """The entries of ``td`` (a read-only dict, do not change it: ``dict(td.items())`` without
    the copy) if it is a plain, unlocked CPU TensorDict of batch size ``batch`` holding tensors
    only, else None (the caller then takes TensorDict's checked path). The env's fast step
    checks its input with it (``benchmarks/bench_train.py``)."""
    if type(td) is not TensorDict or td.is_locked or td.batch_size != batch:
        return None
    if td.device is None or td.device.type != "cpu":
        return None
    items = td._tensordict
    if not all(type(value) is torch.Tensor for value in items.values()):
        return None
    return items


def new_tensordict(
    entries: dict[str, torch.Tensor], batch_size: torch.Size, device: Any = None
) -> TensorDict:
    """``TensorDict(entries, batch_size, device)`` for string keys and tensors whose leading
    dims are ``batch_size``, without the per-entry checks (``TensorDict._new_unsafe``): the
    env's step and the update's diagnostics build one per step (``benchmarks/bench_train.py``).
    The entries dict is taken, not copied."""
    return TensorDict._new_unsafe(entries, batch_size=batch_size, device=device)


def transform_step(
    transform: Any, tensordict: TensorDictBase, next_tensordict: TensorDictBase
) -> TensorDictBase:
    """What a ``TransformedEnv``'s step does with its transform: ``transform._step`` on the
    step's ``"next"`` TensorDict. Called by ``BatchedTransformedEnv``'s fast step, which spares
    TorchRL's generic step, ``step_mdp`` and partial reset (half the loop's time at B = 10,
    ``benchmarks/bench_train.py``)."""
    return transform._step(tensordict, next_tensordict)


def transform_reset(
    transform: Any, tensordict: TensorDictBase, tensordict_reset: TensorDictBase
) -> TensorDictBase:
    """What a ``TransformedEnv``'s reset does with its transform: ``transform._reset`` on the
    reset's output (``tensordict`` holds the ``"_reset"`` mask). The fast partial reset of
    ``BatchedTransformedEnv`` (``benchmarks/bench_train.py``)."""
    return transform._reset(tensordict, tensordict_reset)


def file_writer(experiment: Any) -> Any:
    """The event file writer of a TensorBoard ``SummaryWriter`` (TorchRL's
    ``TensorboardLogger.experiment``), created if need be: ``SummaryWriter._get_file_writer``.
    Not for speed (no benchmark): TorchRL's logger takes no ``purge_step``, so a resumed run
    writes the purge events itself through it."""
    return experiment._get_file_writer()
