"""A run's folder, written as the run goes by :class:`RunWriter`: ``config.yaml``,
``trials.csv``, TensorBoard events, ``checkpoint.pt`` and the trajectory figures, held by one
run at a time (see :mod:`symrl.runs`)."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from symrl.learner.config import RunConfig, config_to_dict
from symrl.learner.config.baselines import used_settings
from symrl.learner.experts import expert_names
from symrl.runs.checkpoint import save_checkpoint
from symrl.runs.tables import flat, fmt, trial_columns

_RUN_FILES = ("config.yaml", "trials.csv", "tb", "checkpoint.pt", "trajectory.png", "evaluate.png")

_SCALARS = (
    ("trial/steps", "steps"),
    ("trial/total_reinforcement", "total_reinforcement"),
    ("trial/collisions", "collisions"),
    ("trial/shielded", "shielded"),
    ("trial/reached_goal", "reached_goal"),
    ("network/neurons", "neurons"),
    ("explore/temperature", "temperature"),
    ("learn/mean_abs_td_error", "mean_abs_td_error"),
    ("learn/replaced_actions", "replaced"),
    ("crossings/open_m", "crossings_open_m"),
    ("crossings/blocked_m", "crossings_blocked_m"),
    ("crossings/borders_blocked", "borders_blocked"),
    ("crossings/dead_end_m", "crossings_dead_end_m"),
    ("goal/passed", "goal_passed"),
    ("goal/refound", "goal_refound"),
    ("trap/wall_follows", "wall_follows"),
    ("odometry/scan_correction_m", "scan_correction_m"),
)
"""TensorBoard tag of each trial column logged per trial."""


class RunWriter:
    """Writes one run's folder as the run goes (see the module docstring)."""

    def __init__(
        self,
        logdir: str | Path,
        config: RunConfig,
        world: Any,
        overwrite: bool = False,
        resume_rows: list[dict[str, Any]] | None = None,
        *,
        columns: list[str] | None = None,
        settings: dict[str, Any] | None = None,
        flag: str = "--logdir",
    ):
        """``resume_rows``: go on with the run already in ``logdir`` whose finished trials are
        these rows (the trial table is rewritten with them, then appended to). ``columns``: the
        trial table's columns (default :func:`trial_columns`); ``settings``: what
        ``config.yaml``, the TensorBoard text and HParams record (default: the config's settings
        its learner reads, :func:`symrl.learner.config.baselines.used_settings`).
        ``flag``: the command's flag naming the folder, in the refusal when another process
        writes it."""
        from torchrl.record.loggers import TensorboardLogger

        from symrl.about import provenance

        self.dir = Path(logdir)
        if self.dir.exists() and not self.dir.is_dir():
            raise FileExistsError(f"--logdir {str(self.dir)!r}: exists and is not a folder")
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise FileExistsError(
                f"--logdir {str(self.dir)!r}: cannot make it ({err.strerror})"
            ) from None
        self._lock = _lock_run_folder(self.dir, flag)
        for leftover in self.dir.glob("checkpoint.pt*.tmp"):  # a save cut short by SIGKILL
            leftover.unlink()
        if resume_rows is not None:
            pass
        elif (self.dir / "config.yaml").exists():
            if not overwrite:
                self.release()
                raise FileExistsError(
                    f"--logdir {str(self.dir)!r}: already holds a run "
                    "(pass --overwrite to replace it)"
                )
            for name in _RUN_FILES:  # nothing of the old run may mix with the new one
                old = self.dir / name
                if old.is_dir():
                    shutil.rmtree(old)
                elif old.exists():
                    old.unlink()
        self.config = config
        self.world = world
        self.expert_names = expert_names(config, world)
        self.provenance = provenance()
        tree = config_to_dict(config)
        self.settings = used_settings(config, tree) if settings is None else settings
        meta = {**self.settings, "provenance": self.provenance}
        (self.dir / "config.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
        self.columns = trial_columns(config, world) if columns is None else list(columns)
        self._csv = open(self.dir / "trials.csv", "w", newline="")  # noqa: SIM115 - kept open
        self._writer = csv.DictWriter(self._csv, fieldnames=self.columns, extrasaction="ignore")
        self._writer.writeheader()
        for row in resume_rows or []:
            self._writer.writerow({k: fmt(row[k]) for k in self.columns if k in row})
        self._csv.flush()
        self.logger = TensorboardLogger(exp_name="tb", log_dir=str(self.dir))
        if resume_rows is not None:
            _purge_from(self.logger.experiment, len(resume_rows) + 1)
        rows = ["| key | value |", "| --- | --- |"]
        rows += [f"| {k} | {v} |" for k, v in flat(self.settings).items()]
        self.logger.experiment.add_text("config", "\n".join(rows), 0)
        self.trials: list[dict[str, Any]] = [dict(r) for r in resume_rows or []]
        self.snapshots = 0

    def snapshot(self, policy: Any, seed: int, state: dict[str, Any]) -> None:
        """Write ``checkpoint.pt`` with the run state ``state`` (atomic: a crash leaves the
        previous one)."""
        save_checkpoint(
            self.dir / "checkpoint.pt",
            policy,
            self.config,
            seed,
            resume=state,
            provenance=self.provenance,
            world=self.world,
        )
        self.snapshots += 1

    def trial(self, record: dict[str, Any], last: bool) -> None:
        """Append one finished trial: CSV row (flushed), TensorBoard scalars and images."""
        self.trials.append(record)
        self._writer.writerow({k: fmt(record[k]) for k in self.columns if k in record})
        self._csv.flush()
        n = record["trial"]
        scalars = [(tag, key) for tag, key in _SCALARS if key in record]
        if "neurons" in record:
            scalars += [(f"network/neurons/{e}", f"neurons_{e}") for e in self.expert_names]
        for tag, key in scalars:  # the columns a learner has (a baseline has no neurons)
            self.logger.log_scalar(tag, float(record[key]), step=n)
        if "path" in record and (last or n == 1 or n % self.config.run.image_every == 0):
            from symrl.figures import trajectory_figure

            fig = trajectory_figure(self.world, record)
            self.logger.experiment.add_figure("trial/trajectory", fig, global_step=n, close=True)
            if "stretches" in record:
                from symrl.figures import crossings_figure

                fig = crossings_figure(self.world, [record])
                self.logger.experiment.add_figure("trial/crossings", fig, global_step=n, close=True)

    def finish(self, policy: Any, seed: int, state: dict[str, Any] | None = None) -> None:
        """Checkpoint (with the run state ``state`` if given: the run can be resumed), last
        trajectory, HParams; close the files."""
        import matplotlib.pyplot as plt

        self._csv.close()
        if policy is not None:  # None: the caller writes its own checkpoint (the baselines)
            save_checkpoint(
                self.dir / "checkpoint.pt",
                policy,
                self.config,
                seed,
                resume=state,
                provenance=self.provenance,
                world=self.world,
            )
        if self.trials:
            from symrl.figures import trajectory_figure

            fig = trajectory_figure(self.world, self.trials[-1])
            fig.savefig(self.dir / "trajectory.png", dpi=120)
            plt.close(fig)
            if "stretches" in self.trials[-1]:
                from symrl.figures import crossings_figure

                fig = crossings_figure(self.world, self.trials)
                fig.savefig(self.dir / "crossings.png", dpi=100)
                plt.close(fig)
            last = self.trials[-5:]
            metrics = {
                "hparam/last5_total_reinforcement": float(
                    np.mean([t["total_reinforcement"] for t in last])
                ),
                "hparam/last5_actions": float(np.mean([t["steps"] for t in last])),
                "hparam/collisions": float(sum(t["collisions"] for t in self.trials)),
            }
            hparams = {
                k: (v if isinstance(v, (int, float, str, bool)) else str(v))
                for k, v in flat(self.settings).items()
            }
            self.logger.experiment.add_hparams(hparams, metrics, run_name=".")
        self.logger.experiment.flush()
        self.logger.experiment.close()

    _closed = False

    def close(self) -> None:
        """Flush and close what is open (the run may have been interrupted)."""
        if not self._csv.closed:
            self._csv.close()
        self.logger.experiment.flush()

    def release(self) -> None:
        """Let another run write this folder (the lock taken when it was opened)."""
        self._lock.release()


def _lock_run_folder(folder: Path, flag: str = "--logdir") -> Any:
    """Hold ``folder/.lock`` while a run writes the folder: a second run into it (two
    ``--overwrite`` at once) is refused instead of mixing its files with the first's
    (:func:`symrl.locks.lock_folder`: an OS lock, a killed run leaves no stale lock)."""
    from symrl.locks import lock_folder

    return lock_folder(folder, flag)


def _purge_from(experiment: Any, step: int) -> None:
    """Tell TensorBoard to drop the events of steps >= ``step`` written before (a resumed run
    repeats the trial that was cut short); what ``SummaryWriter(purge_step=step)`` writes."""
    from tensorboard.compat.proto.event_pb2 import Event, SessionLog

    from symrl.fastpaths import file_writer

    writer = file_writer(experiment)
    writer.add_event(Event(step=step, file_version="brain.Event:2"))
    writer.add_event(Event(step=step, session_log=SessionLog(status=SessionLog.START)))
