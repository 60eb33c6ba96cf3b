"""Soft Actor-Critic from TorchRL on the paper's task (the recipe ``sac``).

TorchRL's ``SACLoss`` (two Q-networks, target Q-networks by Polyak averaging with
``SoftUpdate``, entropy temperature learned toward the target entropy -dim(A)), a uniform
replay buffer, one gradient step per environment transition. The defaults (the config keys
``baseline.sac.*``) are the ones the field runs SAC with (Haarnoja et al. 2018, as
Stable-Baselines3 ships them); none was tuned on this task. The loop, env and run folder are
:mod:`symrl.studies.baseline`'s.
"""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase

from symrl.learner.config.baselines import SACSection
from symrl.studies.actor import make_actor

__all__ = ["SACAgent"]

_KEYS = (
    "observation",
    "control",
    ("next", "observation"),
    ("next", "reward"),
    ("next", "done"),
    ("next", "terminated"),
)


class SACAgent:
    """Acts with the TanhNormal actor (uniform control for the first ``learning_starts``
    transitions), learns with ``SACLoss`` from the replay buffer."""

    def __init__(self, cfg: SACSection, n_obs: int, envs: int) -> None:
        from torch import nn
        from torchrl.data import Bounded, LazyTensorStorage, ReplayBuffer
        from torchrl.modules import MLP, ValueOperator
        from torchrl.objectives import SACLoss, SoftUpdate

        self.cfg, self.envs = cfg, envs
        cells = (cfg.hidden, cfg.hidden)
        self.actor_spec: dict[str, Any] = {"cells": list(cells), "activation": "relu"}
        self.actor = make_actor(n_obs, cells, "relu")
        qvalue = ValueOperator(
            MLP(
                in_features=n_obs + 1,
                out_features=1,
                num_cells=list(cells),
                activation_class=nn.ReLU,
            ),
            in_keys=["observation", "control"],
            out_keys=["state_action_value"],
        )
        self.loss = SACLoss(
            self.actor,
            qvalue,
            num_qvalue_nets=2,
            loss_function="l2",
            alpha_init=cfg.alpha_init,
            action_spec=Bounded(-1.0, 1.0, (1,)),
        )
        self.loss.set_keys(action="control")
        self.loss.make_value_estimator(gamma=cfg.gamma)
        self.target = SoftUpdate(self.loss, tau=cfg.tau)
        self.optim = torch.optim.Adam(self.loss.parameters(), lr=cfg.lr)
        self.buffer = ReplayBuffer(
            storage=LazyTensorStorage(cfg.buffer_size), batch_size=cfg.batch_size
        )
        self.frames = 0
        self.updates = 0

    @torch.no_grad()
    def act(self, td: TensorDictBase) -> TensorDictBase:
        if self.frames < self.cfg.learning_starts:
            td.set("control", torch.rand(self.envs, 1) * 2 - 1)
            return td
        return self.actor(td)

    def observe(self, td: TensorDictBase) -> None:
        self.buffer.extend(td.select(*_KEYS).clone())
        self.frames += self.envs
        if self.frames < self.cfg.learning_starts:
            return
        for _ in range(self.envs * self.cfg.updates_per_step):
            out = self.loss(self.buffer.sample())
            total = out["loss_actor"] + out["loss_qvalue"] + out["loss_alpha"]
            self.optim.zero_grad()
            total.backward()
            self.optim.step()
            self.target.step()
            self.updates += 1

    def state(self) -> dict[str, Any]:
        n = len(self.buffer)
        return {
            "loss": self.loss.state_dict(),  # actor, critics, target critics, temperature
            "actor": self.actor.state_dict(),
            "optim": self.optim.state_dict(),
            # a copy of the rows in use: a view would save the whole 1e6-row storage
            "buffer": self.buffer.storage[:n].clone().to_dict() if n else None,
            "frames": self.frames,
            "updates": self.updates,
        }

    def load_state(self, state: dict[str, Any]) -> None:
        from tensordict import TensorDict

        self.loss.load_state_dict(state["loss"])
        self.actor.load_state_dict(state["actor"])
        self.optim.load_state_dict(state["optim"])
        if state["buffer"] is not None:  # one extend: the same rows in the same slots
            data = TensorDict(state["buffer"])
            self.buffer.extend(data.auto_batch_size_(batch_dims=1))
        self.frames, self.updates = int(state["frames"]), int(state["updates"])
