"""A run of any recipe: the paper's learner (:func:`symrl.runs.run_one`) or a deep-RL baseline
(:func:`symrl.studies.baseline.train_baseline`, a recipe whose ``baseline.algorithm`` is set),
into the same run folder, and a stopped run of either read back to go on with it. The one code
path of ``symrl train``, ``symrl sweep`` and ``symrl baseline``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from symrl.learner.config import RunConfig

__all__ = ["run_recipe", "load_run", "BASELINE_CHECKPOINT_EVERY"]

BASELINE_CHECKPOINT_EVERY = 50
"""Trials between a baseline's periodic checkpoints unless told (each holds its replay buffer)."""


def run_recipe(
    config: RunConfig,
    logdir: str | Path,
    *,
    world: Any = None,
    overwrite: bool = False,
    resume: dict[str, Any] | None = None,
    seed: int | None = None,
    checkpoint_every: int | None = None,
    progress: bool = True,
    stop: Any = None,
) -> Any:
    """Train ``config`` into the run folder ``logdir`` (arguments as
    :func:`symrl.runs.run_one`'s; ``checkpoint_every`` None: every trial for the paper's
    learner, every 50 for a baseline, whose checkpoint holds its replay buffer); its
    :class:`symrl.train.TrainResult`."""
    if config.baseline.algorithm is None:
        from symrl.runs import run_one

        return run_one(
            config,
            logdir,
            world=world,
            overwrite=overwrite,
            resume=resume,
            seed=seed,
            checkpoint_every=checkpoint_every or 1,
            progress=progress,
            stop=stop,
        )
    from symrl.studies.baseline import train_baseline

    return train_baseline(
        config,
        logdir,
        world=world,
        overwrite=overwrite,
        resume=resume,
        checkpoint_every=checkpoint_every or BASELINE_CHECKPOINT_EVERY,
        progress=progress,
        stop=stop,
    )


def load_run(
    run_dir: str | Path, adopt: bool = False
) -> tuple[RunConfig, int, dict[str, Any], Any]:
    """``(config, seed, state, world)`` of the run in folder ``run_dir`` to go on with it, the
    paper learner's (:func:`symrl.runs.load_resume`) or a baseline's
    (:func:`symrl.studies.baseline.load_baseline_resume`); every fault one line."""
    from symrl.runs import load_checkpoint_world, load_resume
    from symrl.studies.baseline_checkpoint import is_baseline_checkpoint, load_baseline_resume

    path = Path(run_dir) / "checkpoint.pt"
    if Path(run_dir).is_dir() and path.is_file() and is_baseline_checkpoint(path):
        return load_baseline_resume(run_dir, adopt)
    config, seed, state = load_resume(run_dir, adopt)
    return config, seed, state, load_checkpoint_world(path)[2]
