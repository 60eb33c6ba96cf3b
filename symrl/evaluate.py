"""Greedy trials of learned controllers (``symrl evaluate``, the studies' other starts).

A batch of robots, each driven by its own controller (or copies of one), each from its own
start pose, one trial each, with TorchRL's DETERMINISTIC exploration type: the policy adds no
noise and stores nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from symrl.learner.config import RunConfig

__all__ = ["rollout", "evaluate", "check_same_regions"]


@torch.inference_mode()
def rollout(policy: Any, env: Any) -> list[dict[str, Any]]:
    """One greedy trial per robot of ``env`` (batch size = ``policy.batch``); their records
    (inference mode: no op needs autograd, as in the training loop)."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from symrl.train import TrialRecorder

    batch = policy.batch
    recorder = TrialRecorder(batch)
    records: list[dict[str, Any] | None] = [None] * batch
    policy.begin_trial(torch.arange(batch))
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        td = env.reset()
        while any(r is None for r in records):
            policy(td)
            td, next_td = env.step_and_maybe_reset(td)
            done = recorder.step(td, torch.zeros(batch))
            for b in np.flatnonzero(done):
                if records[b] is None:  # a robot's first trial is its evaluation
                    record = recorder.finish(int(b))
                    record["reached_goal"] = bool(recorder.reached[b])
                    records[b] = record
            td = next_td
    return records  # type: ignore[return-value]


def check_same_regions(policy: Any, other: Any) -> None:
    """A controller drives in another map only if that map has as many regions (one expert
    and one row of sub-goal options each) and sub-goal options per region; else a one-line
    ``ValueError`` naming both."""
    mine, theirs = policy.state_dict(), other.state_dict()
    for key, what in (("experts.count", "experts"), ("options.q", "regions x sub-goal options")):
        if key in mine and tuple(mine[key].shape[1:]) != tuple(theirs[key].shape[1:]):
            have, need = (" x ".join(map(str, d[key].shape[1:])) for d in (mine, theirs))
            raise ValueError(
                f"the controller has {have} {what} (map {policy.world.name!r}: "
                f"{', '.join(policy.world.regions.names)}), map {other.world.name!r} needs "
                f"{need} ({', '.join(other.world.regions.names)}); a controller drives only in "
                "a map with as many regions and sub-goal options"
            )


def evaluate(
    policy: Any,
    config: RunConfig,
    starts: Sequence[tuple[float, float, float] | None] | None = None,
    seed: int = 0,
    noise: bool = True,
    world: Any = None,
) -> list[dict[str, Any]]:
    """Drive a one-robot controller greedily once from each start (radians; None: the map's
    start), in ``world`` (default: the one it learned in). Returns one record per start."""
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.train import make_env

    starts = list(starts) if starts else [None]
    world = world if world is not None else policy.world
    state = policy.state_dict()
    subgoals = policy.subgoals
    if world is not policy.world:
        fresh = MixtureOfExpertsPolicy(policy.config, world, [seed])
        check_same_regions(policy, fresh)
        # the other map's region rules: the mapper is rebuilt from the map it drives in
        state = {k: (fresh.state_dict()[k] if k.startswith("mapper.") else v)
                 for k, v in state.items()}  # fmt: skip
        subgoals = fresh.subgoals
    copies = MixtureOfExpertsPolicy.from_robot_states(
        policy.config, world, [state] * len(starts), [seed] * len(starts), subgoals
    )
    cfg = config.model_copy(update={"env": config.env.model_copy(update={"noise": noise})})
    env = make_env(cfg, [seed + k for k in range(len(starts))], world=world)
    if any(s is not None for s in starts):
        w = world
        env.set_starts(np.array([s if s is not None else (w.start.x, w.start.y, w.start.heading)
                                 for s in starts], dtype=np.float64))  # fmt: skip
    try:
        return rollout(copies, env)
    finally:
        env.close()
