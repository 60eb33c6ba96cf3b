"""Each shortcut of ``symrl.fastpaths`` gives what the public TorchRL / TensorDict / TensorBoard
call it stands for gives, and no other module of symrl reaches past those libraries' public
names or writes an object's ``__dict__``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import torch
from tensordict import TensorDict
from torchrl.envs import TransformedEnv
from torchrl.envs.transforms import RewardSum
from torchrl.envs.utils import step_mdp

from symrl.fastpaths import (
    file_writer,
    new_tensordict,
    read,
    tensordict_items,
    transform_reset,
    transform_step,
    write,
)
from symrl.world.batched_env import BatchedWorldEnv

SYMRL = Path(__file__).resolve().parents[1] / "symrl"


def _td() -> TensorDict:
    return TensorDict({"a": torch.zeros(3, 2), "next": {"r": torch.ones(3, 1)}}, batch_size=[3])


def test_read_is_getitem_and_get():
    td = _td()
    assert read(td, "a") is td["a"] and read(td, ("next", "r")) is td["next", "r"]
    assert read(td, "missing", None) is None
    with pytest.raises(KeyError, match="missing"):
        read(td, "missing")


def test_write_is_update():
    values = {"a": torch.full((3, 2), 2.0), "b": torch.arange(3)}
    fast, checked = write(_td(), values), _td().update(values)
    assert set(fast.keys(True, True)) == set(checked.keys(True, True))
    assert (fast == checked).all()
    with pytest.raises(RuntimeError):  # the public call's refusal of a wrong batch size
        write(_td(), {"c": torch.zeros(4)})


def test_tensordict_items_are_the_items():
    td = TensorDict({"a": torch.zeros(3, 2), "b": torch.ones(3)}, batch_size=[3], device="cpu")
    items = tensordict_items(td, torch.Size([3]))
    assert items is not None and items == dict(td.items())
    assert tensordict_items(td, torch.Size([4])) is None
    assert tensordict_items(_td(), torch.Size([3])) is None  # a nested TensorDict


def test_new_tensordict_is_the_constructor():
    entries = {"a": torch.zeros(2, 3), "b": torch.arange(2)}
    fast = new_tensordict(dict(entries), torch.Size([2]), "cpu")
    checked = TensorDict(entries, batch_size=[2], device="cpu")
    assert fast.batch_size == checked.batch_size and fast.device == checked.device
    assert set(fast.keys()) == set(checked.keys()) and (fast == checked).all()


def _env() -> TransformedEnv:
    return TransformedEnv(BatchedWorldEnv(size=2, seeds=[0, 1]), RewardSum())


def _stepped() -> tuple[TransformedEnv, TensorDict]:
    env = _env()
    td = env.reset()
    td["action"] = torch.tensor([[0.3], [-0.2]])
    return env, td


def test_transform_step_is_the_transformed_envs_step():
    (stock_env, stock), (env, td) = _stepped(), _stepped()
    expected = stock_env.step(stock)["next"]
    got = transform_step(env.transform, td, env.base_env.step(td.clone())["next"])
    assert set(got.keys()) == set(expected.keys()) and (got == expected).all()


def test_transform_reset_is_the_transformed_envs_partial_reset():
    (stock_env, stock), (env, td) = _stepped(), _stepped()
    stock_env.step(stock)
    td.set("next", transform_step(env.transform, td, env.base_env.step(td.clone())["next"]))
    mask = torch.tensor([[True], [False]])
    stock, td = step_mdp(stock).set("_reset", mask), step_mdp(td).set("_reset", mask.clone())
    expected = stock_env.reset(stock.clone())
    got = transform_reset(env.transform, td, env.base_env.reset(td.clone()))
    assert set(got.keys()) == set(expected.keys())
    assert (got.exclude("_reset") == expected.exclude("_reset")).all()
    assert got["episode_reward"][0].item() == 0.0 and got["episode_reward"][1].item() != 0.0


def test_file_writer_is_the_writers_own(tmp_path):
    tensorboard = pytest.importorskip("torch.utils.tensorboard")
    writer = tensorboard.SummaryWriter(str(tmp_path))
    try:
        writer.add_scalar("x", 1.0, 0)  # the public call that opens the event file
        assert file_writer(writer) is writer.file_writer
    finally:
        writer.close()


# a private name reached on anything but the module itself (``td._tensordict``,
# ``TensorDict._new_unsafe``, ``transform._step``, ``experiment._get_file_writer()``...)
_LIBRARY_PRIVATE = re.compile(
    r"\b(?!self\b|cls\b|super\(\)|os\b)[A-Za-z_][A-Za-z0-9_]*(?:\(\))?"
    r"\._(?!asdict\b|replace\b|fields\b)[a-z][a-z0-9_]*"
)  # a named tuple's _asdict / _replace / _fields are its public API


def _sources() -> list[Path]:
    return sorted(p for p in SYMRL.rglob("*.py") if "recipes" not in p.relative_to(SYMRL).parts)


def test_no_module_but_fastpaths_reaches_private_names_of_other_objects():
    offenders = []
    for path in _sources():
        if path.name == "fastpaths.py":
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            if _LIBRARY_PRIVATE.search(code.replace("``", "")):  # not in a docstring's ``x``
                offenders.append(f"{path.relative_to(SYMRL.parent)}:{n}: {line.strip()}")
    assert offenders == []


def test_no_module_writes_an_objects_dict():
    writes = re.compile(r"__dict__\s*\[[^\]]*\]\s*=(?!=)|__dict__\.(pop|update|setdefault)\(")
    offenders = [
        f"{p.relative_to(SYMRL.parent)}:{n}"
        for p in _sources()
        for n, line in enumerate(p.read_text().splitlines(), 1)
        if writes.search(line)
    ]
    assert offenders == []
