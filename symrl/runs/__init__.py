"""What a run leaves on disk: its folder, config, trial table, TensorBoard events, checkpoint
and figures. The training loop (``symrl.train``) calls :class:`RunWriter` once per trial.

A run folder::

    config.yaml      the resolved config, written when the run starts (with versions)
    trials.csv       one row per finished trial, appended and flushed as it finishes
    tb/              TensorBoard events (scalars per trial, trajectory images, HParams)
    checkpoint.pt    the controller, the config and the map's content (self-contained), and
                     the run state to resume from (``symrl train --resume``); rewritten
                     atomically after every trial (``--checkpoint-every N``) and at the end
    trajectory.png   the last trial's path

A resumed run rewrites ``trials.csv`` from the rows its checkpoint holds, then appends: its trial
table is the one the uninterrupted run would have written.

The package's modules by job: :mod:`~symrl.runs.tables` (the trial table),
:mod:`~symrl.runs.checkpoint` (save, load, resume; checked by :mod:`~symrl.runs.policy_check`),
:mod:`~symrl.runs.folder` (:class:`RunWriter`) and :mod:`~symrl.runs.whole_run` (:func:`run_one`).
"""

from __future__ import annotations

from symrl.learner.experts import expert_names
from symrl.runs.checkpoint import (
    CHECKPOINT_FORMAT,
    CheckpointError,
    atomic_save,
    check_same_run,
    load_checkpoint,
    load_checkpoint_world,
    load_resume,
    map_content,
    read_checkpoint_file,
    save_checkpoint,
)
from symrl.runs.folder import RunWriter
from symrl.runs.policy_check import check_policy_state
from symrl.runs.tables import BASE_COLUMNS, read_trials_csv, trial_columns, write_trials_csv
from symrl.runs.whole_run import finished_trials, run_one

__all__ = [
    "RunWriter",
    "BASE_COLUMNS",
    "trial_columns",
    "expert_names",
    "write_trials_csv",
    "read_trials_csv",
    "save_checkpoint",
    "load_checkpoint",
    "load_resume",
    "check_same_run",
    "read_checkpoint_file",
    "CheckpointError",
    "run_one",
    "finished_trials",
    "CHECKPOINT_FORMAT",
    "atomic_save",
    "map_content",
    "check_policy_state",
    "load_checkpoint_world",
]
