"""The deep-RL baselines' world: the run's config (the paper recipe's env, reflex and shield),
the robots' seeds and the env with the priors' observation."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from symrl.knowledge.reflex import ReflexConfig
from symrl.learner.config import RunConfig, load_config
from symrl.studies.priors import PriorObservation, Priors

__all__ = ["run_config", "robot_seeds", "make_env"]


def run_config(map: str = "hailu2001", seed: int = 100, episodes: int = 20) -> RunConfig:
    """The paper recipe's env, reflex and shield (the world and knowledge the paper's learner
    gets), with this run's map, seed and budget, except the reflex's output sets at their full
    size (``ReflexConfig.peaks`` default, +-pi/2). That is the better base for a residual
    learner: the shielded reflex alone scores 41.8 actions / -21.10 with them and 93.2 /
    -65.45 with `paper`'s halved sets, SAC residual at 20 trials 43.9 / -23.19 against 48.5 /
    -25.45 (seeds 100-104; RESULTS.md, "Modern baselines")."""
    peaks = list(ReflexConfig().peaks)
    return load_config(
        "paper_map",
        [
            f"env.map={map}",
            f"run.seed={seed}",
            f"run.trials={episodes}",
            f"run.image_every={max(episodes // 4, 1)}",
            f"reflex.peaks={peaks}",
        ],
    )


def robot_seeds(seed: int, envs: int) -> list[int]:
    """Robot k's world seed: ``seed`` for k = 0 (the robot of ``symrl train --seed seed``)."""
    return [seed] + [seed * 1000 + k for k in range(1, envs)]


def make_env(config: RunConfig, priors: Priors, seeds: Sequence[int], world: Any = None):
    """``BatchedWorldEnv`` (one robot per seed) with the :class:`PriorObservation` transform."""
    from torchrl.envs import TransformedEnv

    from symrl.assembly import make_env as make_world
    from symrl.world.worldmap import load_map

    world = world if world is not None else load_map(config.env.map)
    base = make_world(config, list(seeds), world=world)
    return TransformedEnv(base, PriorObservation(priors, config, world))
