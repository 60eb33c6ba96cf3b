"""The deep-RL baselines' world: the robots' seeds and the env with the priors' observation,
built from what the recipe tells the robot (``knowledge``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from symrl.learner.config import RunConfig
from symrl.studies.priors import PriorObservation, Priors, priors_of

__all__ = ["robot_seeds", "make_env"]


def robot_seeds(seed: int, envs: int) -> list[int]:
    """Robot k's world seed: ``seed`` for k = 0 (the robot of ``symrl train --seed seed``)."""
    return [seed] + [seed * 1000 + k for k in range(1, envs)]


def make_env(
    config: RunConfig, seeds: Sequence[int], world: Any = None, priors: Priors | None = None
):
    """``BatchedWorldEnv`` of ``world`` (default ``env.map``; one robot per seed) with the
    :class:`PriorObservation` transform of ``priors`` (default: the config's ``baseline``
    section), which reads the region rules from what the recipe tells the robot."""
    from torchrl.envs import TransformedEnv

    from symrl.assembly import make_env as make_world
    from symrl.assembly import told
    from symrl.world.worldmap import load_map

    world = world if world is not None else load_map(config.env.map)
    priors = priors if priors is not None else priors_of(config)
    base = make_world(config, list(seeds), world=world)
    return TransformedEnv(base, PriorObservation(priors, config, told(config, world)))
