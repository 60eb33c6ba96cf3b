"""Greedy trials of learned controllers (``symrl evaluate``, the studies' other starts).

A batch of robots, each driven by its own controller (or copies of one), each from its own
start pose, one trial each, with TorchRL's DETERMINISTIC exploration type: the policy adds no
noise and stores nothing. The copies and their env are built by the assembly
(:func:`symrl.assembly.assemble_greedy`), as a training run's are.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from symrl.learner.config import RunConfig

__all__ = ["rollout", "evaluate"]


@torch.inference_mode()
def rollout(policy: Any, env: Any, progress: str | None = None) -> list[dict[str, Any]]:
    """One greedy trial per robot of ``env`` (batch size = ``policy.batch``; for a learner's
    policy, an env with its perception transform: ``symrl.assembly.assemble_greedy``); their
    records (inference mode: no op needs autograd, as in the training loop). ``progress``: the
    label of a bar counting the batch's steps (on a big world these trials take minutes)."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type
    from tqdm.auto import tqdm

    from symrl.train import TrialRecorder

    batch = policy.batch
    recorder = TrialRecorder(batch)
    records: list[dict[str, Any] | None] = [None] * batch
    policy.begin_trial(torch.arange(batch))
    bar = tqdm(desc=progress, unit="step", leave=False, disable=progress is None)
    with set_exploration_type(ExplorationType.DETERMINISTIC), bar:
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
            bar.update()
    return records  # type: ignore[return-value]


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
    from symrl.assembly import assemble_greedy
    from symrl.world.worldmap import load_map

    starts = list(starts) if starts else [None]
    world = world if world is not None else load_map(config.env.map)
    w = world
    poses = None
    if any(s is not None for s in starts):
        poses = np.array(
            [s if s is not None else (w.start.x, w.start.y, w.start.heading) for s in starts],
            dtype=np.float64,
        )
    cfg = config.model_copy(update={"env": config.env.model_copy(update={"noise": noise})})
    # the copies are told what the policy was told (not the world they are driven in)
    copies, env = assemble_greedy(
        cfg,
        policy.knowledge,
        [policy.state_dict()] * len(starts),
        [seed] * len(starts),
        world,
        poses,
        policy.subgoals,
        env_seeds=[seed + k for k in range(len(starts))],
    )
    try:
        return rollout(copies, env)
    finally:
        env.close()
