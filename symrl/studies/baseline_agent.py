"""SAC and PPO as agents of the training loop: an algorithm (acts, observes, its state) with
the priors' action (:class:`symrl.studies.priors.PriorAction`) as a
:class:`symrl.agent.Agent` (:class:`BaselineAgent`)."""

from __future__ import annotations

from typing import Any, Protocol

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from symrl.agent import LearnsNothing, NoExtraColumns
from symrl.studies.priors import PriorAction

__all__ = ["Algorithm", "BaselineAgent", "ReflexAgent", "algorithms"]


class Algorithm(Protocol):
    """What a deep-RL algorithm is (:class:`symrl.studies.sac.SACAgent`,
    :class:`symrl.studies.ppo.PPOAgent`)."""

    actor: Any
    """TorchRL actor: reads ``observation``, writes ``control`` (checkpointed)."""
    actor_spec: dict[str, Any]
    """``make_actor`` arguments that rebuild ``actor`` (cells, activation)."""

    def act(self, td: TensorDictBase) -> TensorDictBase:
        """Write ``control`` for every robot (exploring)."""
        ...

    def observe(self, td: TensorDictBase) -> None:
        """Learn from one batch [B] of transitions (root + ``next``)."""
        ...

    def state(self) -> dict[str, Any]:
        """Everything the agent has learnt and holds (networks, optimiser, data), as tensors
        and plain values: with it a run goes on between two steps (resume)."""
        ...

    def load_state(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state` (a fresh agent of the same settings)."""
        ...


class _Acting(TensorDictModuleBase):
    """The algorithm's exploring action (``control``), then the priors' ``action``."""

    def __init__(self, algorithm: Algorithm, to_action: PriorAction) -> None:
        super().__init__()
        self.algorithm, self.to_action = algorithm, to_action
        self.in_keys = ["observation", *to_action.in_keys[1:]]
        self.out_keys = ["control", "action", "shielded"]

    def forward(self, td: TensorDictBase) -> TensorDictBase:
        self.algorithm.act(td)
        return self.to_action(td)


class BaselineAgent(NoExtraColumns):
    """``algorithm`` (SAC or PPO) acting through ``to_action`` (its priors), as an
    :class:`symrl.agent.Agent`: no TD error column, no extra columns."""

    def __init__(self, algorithm: Algorithm, to_action: PriorAction) -> None:
        self.algorithm = algorithm
        self.policy = _Acting(algorithm, to_action)

    def learn(self, td: TensorDictBase) -> torch.Tensor | None:
        """The algorithm observes the transitions (and learns when its schedule says)."""
        self.algorithm.observe(td)
        return None

    def state_dict(self) -> dict[str, Any]:
        """The algorithm's state (networks, optimiser, data)."""
        return self.algorithm.state()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state_dict`."""
        self.algorithm.load_state(state)


class _Reflex(TensorDictModuleBase):
    """No correction (``control`` 0), then the priors' action: the shielded reflex."""

    def __init__(self, to_action: PriorAction) -> None:
        super().__init__()
        self.to_action = to_action
        self.in_keys = to_action.in_keys[1:]
        self.out_keys = ["control", "action", "shielded"]

    def forward(self, td: TensorDictBase) -> TensorDictBase:
        td.set("control", torch.zeros(*td.batch_size, 1))
        return self.to_action(td)


class ReflexAgent(LearnsNothing):
    """The paper's shielded fuzzy reflex alone, learning nothing, as an
    :class:`symrl.agent.Agent` (the residual baselines' base: ``to_action`` of residual
    priors; their env writes ``reflex_action``)."""

    def __init__(self, to_action: PriorAction) -> None:
        if not to_action.priors.residual:
            raise ValueError(
                f"ReflexAgent: priors.residual={to_action.priors.residual}: the reflex acts "
                "only through residual priors"
            )
        self.policy = _Reflex(to_action)


def algorithms() -> dict[str, Any]:
    """The algorithms' classes by name (``baseline.algorithm``); each is built from its
    hyper-parameters (``baseline.sac`` / ``baseline.ppo``), the observation size and the
    number of robots."""
    from symrl.studies.ppo import PPOAgent
    from symrl.studies.sac import SACAgent

    return {"sac": SACAgent, "ppo": PPOAgent}
