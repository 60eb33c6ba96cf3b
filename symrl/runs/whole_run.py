"""One run, start to end (:func:`run_one`: the one code path of ``symrl train`` and ``symrl
sweep``), and how far a run folder's run has got."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

from symrl.learner.config import RunConfig
from symrl.runs.folder import RunWriter
from symrl.runs.tables import read_trials_csv


def run_one(
    config: RunConfig,
    logdir: str | Path,
    *,
    world: Any = None,
    overwrite: bool = False,
    resume: dict[str, Any] | None = None,
    seed: int | None = None,
    checkpoint_every: int = 1,
    progress: bool = True,
    stop: Any = None,
) -> Any:
    """Train ``config`` (seed ``config.run.seed``) and write its run folder ``logdir`` as
    ``symrl train`` does; the one code path of ``symrl train`` and ``symrl sweep``.

    ``resume``: the run state of the run already in ``logdir`` (:func:`load_resume`; ``seed``
    then is the seed it returned). ``stop()`` is asked after every step; a stopped run has its
    last finished trial's state saved in ``checkpoint.pt`` (if any trial finished) and its
    :class:`symrl.train.TrainResult` has ``timings["stopped"]`` 1. Returns that result."""
    from symrl.train import check_memory, train_batch
    from symrl.world.worldmap import load_map

    seed = config.run.seed if seed is None else int(seed)
    if world is None:
        world = load_map(config.env.map)
    if resume is None:
        check_memory(config, 1, world)
        writer = RunWriter(logdir, config, world, overwrite=overwrite)
    else:
        writer = RunWriter(logdir, config, world, resume_rows=resume["trials"], flag="--resume")
    every = max(1, int(checkpoint_every))
    latest: list[Any] = [None, False]  # the last snapshot, and whether it is on disk

    def on_trial(b: int, record: dict[str, Any], policy: Any) -> None:
        writer.trial(record, last=record["trial"] == config.run.trials)

    def on_snapshot(snapshot: dict[str, Any]) -> None:
        latest[:] = [snapshot, False]
        n = len(snapshot["trials"])
        if n % every == 0 and n < config.run.trials:
            writer.snapshot(None, seed, snapshot)
            latest[1] = True

    try:
        try:
            (result,) = train_batch(
                config,
                [seed],
                progress=progress,
                on_trial=on_trial,
                world=world,
                on_snapshot=on_snapshot,
                resume=resume,
                stop=stop,
            )
        finally:
            writer.close()
        if result.timings.get("stopped"):
            if latest[0] is not None and not latest[1]:
                writer.snapshot(None, seed, latest[0])
            return result
        writer.finish(result.policy, seed, state=latest[0])
    finally:
        writer.release()
    return result


def finished_trials(logdir: str | Path) -> int:
    """How many trials the run in ``logdir`` has finished and saved (0 if no run is there): the
    rows of its ``trials.csv`` when its ``checkpoint.pt`` is written too."""
    folder = Path(logdir)
    if not (folder / "trials.csv").is_file() or not (folder / "checkpoint.pt").is_file():
        return 0
    try:
        return len(read_trials_csv(folder / "trials.csv"))
    except (OSError, csv.Error, UnicodeDecodeError):
        return 0
