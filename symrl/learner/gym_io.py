"""Cheaper per-step conversions between the gymnasium env and TorchRL (``symrl.train.make_env``).

- :class:`InfoReader`: TorchRL's ``default_info_dict_reader`` converts each numpy value through
  the tensordict's generic conversion (~60 us CPU a step for our three keys); this one converts
  each value with ``torch.as_tensor`` to the dtype of its spec and sets a ready tensor (~18 us).
  Same keys, specs and values; a key missing from ``info`` gets the spec's zero, as before.
- :class:`SymrlGymEnv`: a ``GymEnv`` whose observation, reward and action readers skip the
  generic spec encoding when the value already has the spec's dtype and shape (they always do
  here): ``torch.from_numpy`` shares the array as ``torch.as_tensor`` in ``spec.encode`` did,
  so the tensors are the same; anything else goes through TorchRL's own readers. ~90 us a step.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Composite, TensorSpec
from torchrl.envs import GymEnv
from torchrl.envs.gym_like import BaseInfoDictReader

__all__ = ["InfoReader", "SymrlGymEnv"]


class InfoReader(BaseInfoDictReader):
    """Read ``spec``'s keys from ``info`` into the step's tensordict."""

    def __init__(self, spec: dict[str, TensorSpec]) -> None:
        self._info_spec = Composite(dict(spec), shape=[])
        self._keys = [(key, s.dtype, s.shape) for key, s in spec.items()]

    def __call__(self, info_dict: dict[str, Any], tensordict: TensorDictBase) -> TensorDictBase:
        for key, dtype, shape in self._keys:
            value = info_dict.get(key)
            if value is None:
                tensordict.set(key, self._info_spec[key].zero())
                continue
            tensor = torch.as_tensor(value, dtype=dtype)
            if tensor.shape != shape:
                raise ValueError(
                    f"info[{key!r}] has shape {tuple(tensor.shape)}, its spec {tuple(shape)}"
                )
            tensordict.set(key, tensor)
        return tensordict

    def reset(self) -> None:  # the keys are fixed: nothing to forget
        pass

    @property
    def info_spec(self) -> Composite:
        return self._info_spec


class SymrlGymEnv(GymEnv):
    """``GymEnv`` with shortcuts in ``read_obs`` / ``read_reward`` / ``read_action``."""

    _obs_layout: dict[str, tuple[np.dtype, tuple[int, ...]]] | None = None

    def read_obs(self, observations: Any) -> dict[str, Any]:
        layout = self._obs_layout
        if layout is None:
            specs = self.observation_spec
            layout = self._obs_layout = {
                key: (np.dtype(torch.empty((), dtype=spec.dtype).numpy().dtype), tuple(spec.shape))
                for key, spec in specs.items()
                if isinstance(key, str) and spec.dtype is not None and spec.dtype.is_floating_point
            }
        if type(observations) is not dict or "state" in observations:  # TorchRL renames it
            return super().read_obs(observations)
        out = {}
        for key, value in observations.items():
            want = layout.get(key)
            if (
                want is not None
                and type(value) is np.ndarray
                and value.dtype == want[0]
                and value.shape == want[1]
                and value.flags.c_contiguous
            ):
                out[key] = torch.from_numpy(value)
            else:  # not what the spec says: TorchRL's own encoding (casts, reshapes, checks)
                out[key] = self.observation_spec[key].encode(value, ignore_device=True)
        return out

    def read_reward(self, reward: Any) -> torch.Tensor:
        spec = self.reward_spec
        if isinstance(reward, float) and tuple(spec.shape) == (1,):
            return torch.tensor([reward], dtype=spec.dtype)  # as encode: one float, cast once
        return super().read_reward(reward)

    def read_action(self, action: Any) -> Any:
        if type(action) is torch.Tensor and action.device.type == "cpu":
            return action.detach().numpy()  # what spec.to_numpy(action, safe=False) returns
        return super().read_action(action)
