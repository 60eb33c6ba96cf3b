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

from symrl.agent import LearnsNothing
from symrl.learner.config import RunConfig
from symrl.loop import RobotTrials, TrainingLoop
from symrl.recorder import TrialRecorder

__all__ = ["GreedyDriver", "rollout", "evaluate"]


class GreedyDriver(LearnsNothing):
    """A controller driven greedily through the training loop: it learns nothing (its TD error
    column is 0, as a learner's with nothing to correct) and adds no columns."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self._zeros = torch.zeros(policy.batch)

    def learn(self, td: Any) -> torch.Tensor:
        return self._zeros


@torch.inference_mode()
def rollout(policy: Any, env: Any, progress: str | None = None) -> list[dict[str, Any]]:
    """One greedy trial per robot of ``env`` (batch size = ``policy.batch``; for a learner's
    policy, an env with its perception transform: ``symrl.assembly.assemble_greedy``); their
    records. The one training loop drives them (:class:`symrl.loop.TrainingLoop`, TorchRL's
    DETERMINISTIC exploration type, a table of one trial per robot), in inference mode as a
    training run. ``progress``: the label of a bar counting the batch's steps (on a big world
    these trials take minutes)."""
    from torchrl.envs.utils import ExplorationType
    from tqdm.auto import tqdm

    from symrl.collector import StepCollector

    batch = policy.batch
    policy.begin_trial(torch.arange(batch))
    collector = StepCollector(env, policy, exploration_type=ExplorationType.DETERMINISTIC)
    table = RobotTrials(batch, 1)  # a robot's first trial is its evaluation
    with tqdm(desc=progress, unit="step", leave=False, disable=progress is None) as bar:
        loop = TrainingLoop(
            collector,
            GreedyDriver(policy),
            table,
            TrialRecorder(batch),
            on_step=bar.update,
            progress=False,
        )
        loop.run()
    return [{k: v for k, v in rows[0].items() if k != "trial"} for rows in table.rows]


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
