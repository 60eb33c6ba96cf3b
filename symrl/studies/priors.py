"""The paper's prior knowledge, handed to a deep-RL baseline the way the field hands it over.

Residual reinforcement learning (Johannink et al. 2019; Silver et al. 2018): the learned policy
outputs a *correction* that is added to a hand-made controller's action. Here the controller is
symrl's fuzzy reflex steering toward the goal, and the IR shield stays the last step of the data
flow, as in the paper's learner (docs/explanation/architecture.md):

    residual:   action = shield(clip(reflex(sonar, goal angle) + correction * pi * control))
    scratch:    action = pi * control

``control`` in [-1, 1] is what the baseline's network outputs (a TanhNormal sample);
``correction`` is the stated fraction of pi it may move the reflex's action by. The region map
enters as a one-hot of the odometry pose's region in the observation. Two parts, joined by
TensorDict keys:

- :class:`PriorObservation`, an env ``Transform``: writes ``observation`` (24 sonars, goal
  distance / 5 m, goal angle / pi, [region one-hot], [reflex action / pi]) and, with the
  residual, ``reflex_action`` -- on the root and on ``next`` alike, so a replay buffer holds the
  next state's features too;
- :class:`PriorAction`, a ``TensorDictModuleBase`` after the network: ``control`` -> ``action``
  and ``shielded``.

Sub-goals are not offered: the paper's options pick one of a region's sub-goals (a discrete
choice per region entry, learned by its own critic) while SAC and PPO here learn one continuous
action; joining the two is a hybrid-action method of its own, not a switch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.data import Bounded, Composite, Unbounded
from torchrl.envs import Transform

from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.regions import RegionMapper
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.learner.config import RunConfig

__all__ = ["Priors", "PriorObservation", "PriorAction", "observation_size", "priors_of"]

_GOAL_SCALE = 5.0
"""Metres that normalise the goal distance (the sonar range)."""


@dataclass(frozen=True)
class Priors:
    """Which of the paper's priors a baseline gets (all off: from scratch)."""

    residual: bool = False
    """Act as the shielded reflex plus a learned correction (else: the action itself)."""
    regions: bool = False
    """Append the one-hot region id of the odometry pose to the observation."""
    correction: float = 0.25
    """Largest correction, as a fraction of pi (0.25: +-45 deg; the reflex's own turns reach
    +-90 deg). Set once, not tuned."""

    def __post_init__(self) -> None:
        c = self.correction
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 0 < c <= 1:
            raise ValueError(f"--correction {c!r}: must be a fraction of pi in (0, 1]")

    def label(self) -> str:
        """Short name of the variant: scratch, residual, regions, residual+regions."""
        parts = [
            name for name, on in (("residual", self.residual), ("regions", self.regions)) if on
        ]
        return "+".join(parts) or "scratch"


def priors_of(config: RunConfig) -> Priors:
    """The priors ``config``'s ``baseline`` section hands its baseline."""
    b = config.baseline
    return Priors(residual=b.residual, regions=b.regions, correction=b.bound)


def observation_size(priors: Priors, sensors: int, regions: int) -> int:
    """Length of the ``observation`` vector."""
    return sensors + 2 + (regions if priors.regions else 0) + (1 if priors.residual else 0)


class PriorObservation(Transform):
    """Writes ``observation`` (and ``reflex_action`` with the residual) from the raw keys;
    the region one-hot from the region rules of ``told`` (what the robot is told, a
    :class:`symrl.knowledge.rungs.Knowledge`, or a whole map)."""

    def __init__(self, priors: Priors, config: RunConfig, told: Any) -> None:
        out = ["observation"] + (["reflex_action"] if priors.residual else [])
        super().__init__(in_keys=["sonar", "goal", "odometry"], out_keys=out)
        self.priors = priors
        self.reflex = FuzzyReflex(config.reflex) if priors.residual else None
        self.regions = RegionMapper(told.regions) if priors.regions else None
        self.n_regions = len(told.regions.names)
        self.size = observation_size(priors, config.env.robot.n_sensors, self.n_regions)

    def _features(self, td: TensorDictBase) -> TensorDictBase:
        sonar, goal = td.get("sonar"), td.get("goal")
        parts = [sonar, goal[..., :1] / _GOAL_SCALE, goal[..., 1:] / math.pi]
        if self.regions is not None:
            ids = self.regions.ids(td.get("odometry")[..., :2].to(torch.float64))
            parts.append(torch.nn.functional.one_hot(ids, self.n_regions).to(sonar.dtype))
        if self.reflex is not None:
            angle = self.reflex(sonar.to(torch.float64), goal[..., 1].to(torch.float64))
            reflex = angle.to(sonar.dtype).unsqueeze(-1)
            td.set("reflex_action", reflex)
            parts.append(reflex / math.pi)
        td.set("observation", torch.cat(parts, dim=-1))
        return td

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return self._features(next_tensordict)

    def _reset(
        self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase
    ) -> TensorDictBase:
        return self._features(tensordict_reset)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        return self._features(tensordict)

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        shape = observation_spec.shape
        observation_spec["observation"] = Unbounded((*shape, self.size), dtype=torch.float32)
        if self.reflex is not None:
            observation_spec["reflex_action"] = Bounded(
                -math.pi, math.pi, (*shape, 1), dtype=torch.float32
            )
        return observation_spec


class PriorAction(TensorDictModuleBase):
    """``control`` (..., 1) in [-1, 1] -> the env's ``action`` (..., 1) and ``shielded`` (...)."""

    def __init__(self, priors: Priors, config: RunConfig) -> None:
        super().__init__()
        self.priors = priors
        self.in_keys = ["control"] + (["reflex_action", "ir"] if priors.residual else [])
        self.out_keys = ["action", "shielded"]
        self.shield = (
            IRShield(ShieldConfig(margin=config.shield.margin), config.env.robot)
            if priors.residual
            else None
        )

    @torch.no_grad()
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        control = td.get("control").clamp(-1.0, 1.0)
        if self.shield is None:
            alpha = (math.pi * control.to(torch.float64)).squeeze(-1)
            shielded = torch.zeros(alpha.shape, dtype=torch.bool)
        else:
            reflex = td.get("reflex_action").to(torch.float64)
            step = self.priors.correction * math.pi * control.to(torch.float64)
            alpha = (reflex + step).clamp(-math.pi, math.pi).squeeze(-1)
            alpha, shielded = self.shield(td.get("ir"), alpha)
        td.set("action", alpha.to(torch.float32).unsqueeze(-1))
        td.set("shielded", shielded)
        return td
