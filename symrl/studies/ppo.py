"""Proximal Policy Optimisation from TorchRL on the paper's task (the recipe ``ppo``).

TorchRL's ``ClipPPOLoss`` with ``GAE`` advantages, CleanRL's continuous-control defaults
(``ppo_continuous_action.py``; the config keys ``baseline.ppo.*``, none tuned on this task):
2048 transitions per update, 10 epochs of 64-transition minibatches, a TanhNormal actor and a
value critic, both 2x64 tanh MLPs. The transitions come from ``envs`` robots stepped together
(on-policy data from parallel envs, as PPO is usually run): 8 robots x 256 steps make one
2048-transition batch. The loop, env and run folder are :mod:`symrl.studies.baseline`'s.
"""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase

from symrl.learner.config.baselines import PPOSection
from symrl.studies.actor import make_actor

__all__ = ["PPOAgent"]

_KEYS = (
    "observation",
    "control",
    "control_log_prob",
    ("next", "observation"),
    ("next", "reward"),
    ("next", "done"),
    ("next", "terminated"),
)


class PPOAgent:
    """Acts with the TanhNormal actor; every ``frames_per_batch`` transitions, GAE and
    ``epochs`` passes of clipped-PPO minibatch steps."""

    def __init__(self, cfg: PPOSection, n_obs: int, envs: int) -> None:
        from torch import nn
        from torchrl.modules import MLP, ValueOperator
        from torchrl.objectives import ClipPPOLoss
        from torchrl.objectives.value import GAE

        self.cfg, self.envs = cfg, envs
        cells = (cfg.hidden, cfg.hidden)
        self.actor_spec: dict[str, Any] = {"cells": list(cells), "activation": "tanh"}
        self.actor = make_actor(n_obs, cells, "tanh")
        critic = ValueOperator(
            MLP(in_features=n_obs, out_features=1, num_cells=list(cells), activation_class=nn.Tanh),
            in_keys=["observation"],
        )
        self.gae = GAE(gamma=cfg.gamma, lmbda=cfg.lmbda, value_network=critic, average_gae=True)
        self.loss = ClipPPOLoss(
            self.actor,
            critic,
            clip_epsilon=cfg.clip,
            entropy_bonus=cfg.entropy_coef > 0,
            entropy_coeff=cfg.entropy_coef,
            critic_coeff=cfg.critic_coef,
        )
        self.loss.set_keys(action="control", sample_log_prob="control_log_prob")
        self.optim = torch.optim.Adam(self.loss.parameters(), lr=cfg.lr)
        self.steps: list[TensorDictBase] = []
        self.updates = 0

    @torch.no_grad()
    def act(self, td: TensorDictBase) -> TensorDictBase:
        return self.actor(td)

    def observe(self, td: TensorDictBase) -> None:
        self.steps.append(td.select(*_KEYS).clone())
        if len(self.steps) * self.envs < self.cfg.frames_per_batch:
            return
        batch = torch.stack(self.steps, dim=1)  # (B, T): time is the last batch dim
        self.steps = []
        with torch.no_grad():
            self.gae(batch)
        flat = batch.reshape(-1)
        n, size = flat.numel(), self.cfg.minibatch
        for _ in range(self.cfg.epochs):
            order = torch.randperm(n)
            for start in range(0, n - size + 1, size):
                out = self.loss(flat[order[start : start + size]])
                total = out["loss_objective"] + out["loss_critic"]
                entropy = out.get("loss_entropy", None)
                if entropy is not None:
                    total = total + entropy
                self.optim.zero_grad()
                total.backward()
                torch.nn.utils.clip_grad_norm_(self.loss.parameters(), self.cfg.max_grad_norm)
                self.optim.step()
                self.updates += 1

    def state(self) -> dict[str, Any]:
        return {
            "loss": self.loss.state_dict(),  # actor and critic
            "actor": self.actor.state_dict(),
            "critic": self.gae.value_network.state_dict(),
            "optim": self.optim.state_dict(),
            "steps": [td.to_dict() for td in self.steps],  # the batch being collected
            "updates": self.updates,
        }

    def load_state(self, state: dict[str, Any]) -> None:
        from tensordict import TensorDict

        self.loss.load_state_dict(state["loss"])
        self.actor.load_state_dict(state["actor"])
        self.gae.value_network.load_state_dict(state["critic"])
        self.optim.load_state_dict(state["optim"])
        self.steps = [TensorDict(d, batch_size=[self.envs]) for d in state["steps"]]
        self.updates = int(state["updates"])
