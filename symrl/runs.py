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
"""

from __future__ import annotations

import csv
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

from symrl.learner.config import ConfigError, RunConfig, config_from_dict, config_to_dict
from symrl.learner.experts import expert_names

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
    "read_checkpoint_file",
    "CheckpointError",
    "run_one",
    "finished_trials",
]

CHECKPOINT_FORMAT = 3
"""3: the controller's learned counters under ``progress.`` and its option critic under
``options.critic.`` (format 2 held them at the top and under ``options.``)."""
_RUN_FILES = ("config.yaml", "trials.csv", "tb", "checkpoint.pt", "trajectory.png", "evaluate.png")
_BASE_COLUMNS = (
    "trial",
    "steps",
    "total_reinforcement",
    "collisions",
    "shielded",
    "reached_goal",
    "neurons",
    "temperature",
    "replaced",
    "improved",
    "mean_abs_td_error",
    "path_length",
)


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
)
"""TensorBoard tag of each trial column logged per trial."""

BASE_COLUMNS: tuple[str, ...] = _BASE_COLUMNS
"""The columns every trial table starts with (a learner fills those it has)."""


class CheckpointError(ValueError):
    """A checkpoint file cannot be used; the message names the file and the fault."""


def trial_columns(config: RunConfig, world: Any) -> list[str]:
    """Columns of the trial table of a run (fixed before its first trial)."""
    columns = list(_BASE_COLUMNS)
    columns += [f"neurons_{name}" for name in expert_names(config, world)]
    if config.options.enabled:
        columns += [f"option_{name}" for name in world.regions.names]
    if config.crossings.enabled:
        columns += ["crossings_open_m", "crossings_blocked_m", "borders_blocked"]
    return columns


def _fmt(value: Any) -> Any:
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return value


def write_trials_csv(
    path: str | Path, rows: list[dict[str, Any]], columns: list[str] | None = None
) -> None:
    """One row per trial (or per set and trial), every scalar column; paths are left out."""
    if columns is None:
        seen: dict[str, None] = {}
        for row in rows:
            for k, v in row.items():
                if not isinstance(v, (list, tuple, dict)):
                    seen.setdefault(k)
        columns = list(seen)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _fmt(row[k]) for k in columns if k in row})


def read_trials_csv(path: str | Path) -> list[dict[str, Any]]:
    """Read a trial table back with numbers as numbers."""

    def num(v: str) -> Any:
        if v in ("True", "False"):
            return v == "True"
        for kind in (int, float):
            try:
                return kind(v)
            except ValueError:
                pass
        return v

    with open(path, newline="") as fh:
        return [{k: num(v) for k, v in row.items() if v != ""} for row in csv.DictReader(fh)]


# ---------------------------------------------------------------------------------------------
# Checkpoints


def _atomic_save(obj: Any, path: Path) -> None:
    """torch.save to a temporary file in the same folder, then rename: never half a file."""
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        torch.save(obj, tmp)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a run's files are readable alike
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _map_content(world: Any) -> dict[str, Any] | None:
    """The map file's parsed content, so a checkpoint does not depend on the file staying."""
    source = Path(str(getattr(world, "source", "")))
    if source.is_file():
        return yaml.safe_load(source.read_text())
    return None


def save_checkpoint(
    path: str | Path,
    policy: Any,
    config: RunConfig,
    seed: int,
    resume: dict[str, Any] | None = None,
    provenance: dict[str, Any] | None = None,
    world: Any = None,
) -> None:
    """The controller of one robot (a B = 1 policy), its config, seed and map content; with
    ``resume`` (a :func:`symrl.train.run_snapshot`) also the whole run state, so that
    ``symrl train --resume`` can go on from it (``load_checkpoint`` ignores it)."""
    path = Path(path)
    if provenance is None:
        from symrl.about import provenance as current

        provenance = current()
    data = {
        "format": CHECKPOINT_FORMAT,
        "provenance": provenance,
        "config": config_to_dict(config),
        "map": _map_content(world),
        "seed": int(seed),
        "policy": resume["policy"] if resume is not None else policy.state_dict(),
    }
    if resume is not None:
        data["resume"] = resume
    _atomic_save(data, path)


def load_resume(run_dir: str | Path, adopt: bool = False) -> tuple[RunConfig, int, dict[str, Any]]:
    """``(config, seed, state)`` of the run in folder ``run_dir`` to resume it; every fault
    (no such folder, no checkpoint, a checkpoint without run state or of another format, a
    checkpoint whose recipe, seed, map or settings differ from the folder's ``config.yaml``
    unless ``adopt``) is a one-line :class:`CheckpointError`."""
    from symrl.train import SNAPSHOT_FORMAT

    folder = Path(run_dir)
    if folder.exists() and not folder.is_dir():
        raise CheckpointError(f"--resume {str(folder)!r}: is a file; pass the run folder")
    if not folder.is_dir():
        raise CheckpointError(f"--resume {str(folder)!r}: no such run folder")
    path = folder / "checkpoint.pt"
    if not path.is_file():
        raise CheckpointError(f"--resume {str(folder)!r}: no checkpoint.pt in it")
    _, config = load_checkpoint(path)  # checks format, config, map and weights
    data = torch.load(path, map_location="cpu", weights_only=True)
    state = data.get("resume")
    if not isinstance(state, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: checkpoint.pt holds a controller only, no run state "
            "to resume from"
        )
    if state.get("format") != SNAPSHOT_FORMAT:
        raise CheckpointError(
            f"--resume {str(folder)!r}: run state format {state.get('format')!r}, this symrl "
            f"resumes format {SNAPSHOT_FORMAT}"
        )
    seed = int(data["seed"])
    if not adopt:
        _check_same_run(folder, config, seed)
    return config, seed, state


def _check_same_run(folder: Path, config: RunConfig, seed: int) -> None:
    """The checkpoint of ``folder`` belongs to the run its ``config.yaml`` records: the same
    settings (the trial budget aside, which ``--trials`` may extend) and seed."""
    recorded_file = folder / "config.yaml"
    if not recorded_file.is_file():
        return
    try:
        recorded = yaml.safe_load(recorded_file.read_text())
    except (OSError, yaml.YAMLError, UnicodeDecodeError):
        recorded = None
    if not isinstance(recorded, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: config.yaml is not readable, so checkpoint.pt cannot be "
            "checked against it; pass --adopt-checkpoint to go on with the checkpoint's config"
        )
    saved = _flat(config_to_dict(config))
    saved["run.seed"] = seed
    have = _flat({k: v for k, v in recorded.items() if k != "provenance"})
    for key in ("recipe", "run.seed", "env.map", *sorted(set(saved) | set(have))):
        if key == "run.trials" or saved.get(key) == have.get(key):
            continue
        raise CheckpointError(
            f"--resume {str(folder)!r}: checkpoint.pt has {key}={saved.get(key)!r} but the "
            f"folder's config.yaml {key}={have.get(key)!r}: not this folder's run; pass "
            "--adopt-checkpoint to go on with the checkpoint's run"
        )


def read_checkpoint_file(path: Path, name: str) -> Any:
    """The content of the checkpoint file ``path`` (tensors and plain values only); a file
    that cannot be read is a one-line :class:`CheckpointError` that starts with ``name``."""
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # noqa: BLE001 - any unreadable file is the same user error
        detail = str(err).splitlines()[0][:120] if str(err) else type(err).__name__
        raise CheckpointError(f"{name}: not a readable symrl checkpoint ({detail})") from None


_DERIVED = ("code_centres", "mapper.", "reflex.")
"""State entries rebuilt from the config and the map: a checkpoint's must equal them."""
_ANGLES = ("experts.actions", "experts.means", "experts.taken")
_MAX_ANGLE = 2 * math.pi
_AT_LEAST = {
    "progress.trials_done": 0,
    "options.critic.n": 0,
    "options.critic.trials": 0,
    "options.stage": 0,
    "progress.temperature": 0.0,
    "options.critic.epsilon": 0.0,
}


def _outside(values: torch.Tensor, low: int, high: int) -> int | None:
    """A value of the integer tensor ``values`` outside ``low..high`` (its largest when that is
    too high, else its smallest), or None when all are within."""
    if not values.numel():
        return None
    smallest, largest = int(values.min()), int(values.max())
    return largest if largest > high else smallest if smallest < low else None


def check_policy_state(state: dict[str, Any], fresh: dict[str, torch.Tensor]) -> str | None:
    """The first fault of a saved controller ``state`` against ``fresh``, the state dict of the
    controller its config and map build (None: it can be loaded): an entry missing, unknown, not
    a tensor or of another dtype; a non-finite number; an entry rebuilt from the config and the
    map that differs from it; a neuron count, option or region index out of range; an angle
    beyond 2 pi; a count, temperature or epsilon below 0 (epsilon above 1)."""
    missing = sorted(set(fresh) - set(state))
    if missing:
        return f"weights do not match its config and map ({missing[0]} is missing)"
    for key, value in state.items():
        if key not in fresh:
            return f"weights do not match its config and map ({key} is unknown to them)"
        if not isinstance(value, torch.Tensor):
            return f"policy entry {key} is not a tensor ({type(value).__name__})"
        want = fresh[key]
        if value.dtype != want.dtype:
            return (
                f"weights do not match its config and map ({key} has dtype {value.dtype}, "
                f"not {want.dtype})"
            )
        # best_total is -inf until a trial reaches the goal; nothing else may be non-finite
        ok = torch.isfinite(value) | ((key == "progress.best_total") & (value == -torch.inf))
        if value.is_floating_point() and not bool(ok.all()):
            return f"non-finite values in {key}"
        if key.startswith(_DERIVED) and not (
            value.shape == want.shape and bool(torch.equal(value, want))
        ):
            return f"weights do not match its config and map ({key} differs from theirs)"
    for key, low in _AT_LEAST.items():
        if key in state and state[key].numel() and float(state[key].min()) < low:
            return f"policy entry {key} holds {float(state[key].min()):g}, below {low:g}"
    epsilon = state.get("options.critic.epsilon")
    if epsilon is not None and epsilon.numel() and float(epsilon.max()) > 1.0:
        return f"policy entry options.critic.epsilon holds {float(epsilon.max()):g}, above 1"
    for key in _ANGLES:
        if key in state and state[key].numel():
            big = float(state[key].abs().max())
            if big > _MAX_ANGLE:
                return f"policy entry {key} holds an angle of {big:g} rad, beyond 2 pi"
    if "experts.count" in state and "experts.used" in state:
        count, used = state["experts.count"], state["experts.used"]
        capacity = used.shape[2] if used.dim() >= 3 else 0
        bad = _outside(count, 0, capacity)
        if bad is not None:
            return (
                f"policy entry experts.count holds {bad} neurons, outside 0..{capacity} "
                "(the stored neurons)"
            )
    # an option index (the critic's last axis) and a region index (its second last), -1: none
    for key, axis, what in (("options.choice", -1, ""), ("options.visit", -2, "region ")):
        if key in state and "options.critic.q" in state:
            top = state["options.critic.q"].shape[axis] - 1
            bad = _outside(state[key], -1, top)
            if bad is not None:
                return f"policy entry {key} holds {what}{bad}, outside -1..{top}"
    return None


def load_checkpoint(path: str | Path) -> tuple[Any, RunConfig]:
    """Rebuild ``(policy, config)`` from :func:`save_checkpoint`; every fault of the file is a
    one-line :class:`CheckpointError`."""
    policy, config, _ = load_checkpoint_world(path)
    return policy, config


def load_checkpoint_world(path: str | Path) -> tuple[Any, RunConfig, Any]:
    """:func:`load_checkpoint` and the world the robot learned in (the checkpoint's map; the
    policy holds only what its recipe's ``knowledge`` tells it)."""
    from symrl.assembly import build_policy
    from symrl.world.worldmap import MapError, load_map

    path = Path(path)
    if path.is_dir():
        raise CheckpointError(
            f"checkpoint {str(path)!r}: is a folder; pass the checkpoint.pt file in it"
        )
    if not path.exists():
        raise CheckpointError(f"checkpoint {str(path)!r}: no such file")
    if not path.is_file():
        raise CheckpointError(
            f"checkpoint {str(path)!r}: not a regular file (a device, pipe or socket); pass the "
            "checkpoint.pt a run wrote"
        )
    data = read_checkpoint_file(path, f"checkpoint {str(path)!r}")
    if not isinstance(data, dict) or "config" not in data or "policy" not in data:
        raise CheckpointError(f"checkpoint {str(path)!r}: not written by symrl train")
    if data.get("format") != CHECKPOINT_FORMAT:
        raise CheckpointError(
            f"checkpoint {str(path)!r}: format {data.get('format')!r}, this symrl reads "
            f"format {CHECKPOINT_FORMAT}"
        )
    kinds = (("config", dict), ("policy", dict), ("seed", int))
    for key, kind in kinds:
        value = data.get(key, 0 if key == "seed" else None)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise CheckpointError(
                f"checkpoint {str(path)!r}: {key} must be a {kind.__name__}, got "
                f"{type(value).__name__}"
            )
    try:
        cfg = dict(data["config"])
        config = config_from_dict(cfg, recipe=str(cfg.get("recipe", "checkpoint")))
        world = load_map(data["map"]) if data.get("map") else load_map(config.env.map)
    except (ConfigError, MapError) as err:
        raise CheckpointError(f"checkpoint {str(path)!r}: {err}") from None
    policy = build_policy(config, world, [int(data.get("seed", config.run.seed))])
    state = data["policy"]
    fault = check_policy_state(state, policy.state_dict())
    if fault:
        raise CheckpointError(f"checkpoint {str(path)!r}: {fault}")
    try:
        policy.load_state_dict(state)
    except (RuntimeError, KeyError, TypeError) as err:
        lines = [line.strip() for line in str(err).splitlines() if line.strip()]
        detail = (lines[1] if len(lines) > 1 else lines[0] if lines else type(err).__name__)[:200]
        raise CheckpointError(
            f"checkpoint {str(path)!r}: weights do not match its config ({detail})"
        ) from None
    return policy, config, world


# ---------------------------------------------------------------------------------------------
# The run folder


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
        ``config.yaml``, the TensorBoard text and HParams record (default the whole config) --
        a learner other than the paper's (the baselines) names only the settings it uses.
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
        self.settings = config_to_dict(config) if settings is None else settings
        meta = {**self.settings, "provenance": self.provenance}
        (self.dir / "config.yaml").write_text(yaml.safe_dump(meta, sort_keys=False))
        self.columns = trial_columns(config, world) if columns is None else list(columns)
        self._csv = open(self.dir / "trials.csv", "w", newline="")  # noqa: SIM115 - kept open
        self._writer = csv.DictWriter(self._csv, fieldnames=self.columns, extrasaction="ignore")
        self._writer.writeheader()
        for row in resume_rows or []:
            self._writer.writerow({k: _fmt(row[k]) for k in self.columns if k in row})
        self._csv.flush()
        self.logger = TensorboardLogger(exp_name="tb", log_dir=str(self.dir))
        if resume_rows is not None:
            _purge_from(self.logger.experiment, len(resume_rows) + 1)
        rows = ["| key | value |", "| --- | --- |"]
        rows += [f"| {k} | {v} |" for k, v in _flat(self.settings).items()]
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
        self._writer.writerow({k: _fmt(record[k]) for k in self.columns if k in record})
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
                for k, v in _flat(self.settings).items()
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


def _flat(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict) and key not in ("near", "sectors"):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


# ---------------------------------------------------------------------------------------------
# One run, start to end


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
