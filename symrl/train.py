"""Online training with a TorchRL Collector, readable top to bottom (``symrl train RECIPE``).

seeds -> env (GymEnv + info reader) -> policy (MixtureOfExpertsPolicy) -> loss (TeseoLoss)
-> Collector(frames_per_batch=1) -> per step: loss update; at ("next", "done"): end of trial
(record, action replacement, cooling, logging). The budget is a number of trials.

Outputs of ``train_command`` in the run folder: TensorBoard events (``tb/``), ``trials.csv``,
``config.yaml`` (resolved), ``checkpoint.pt`` (config + state dict, enough to rebuild and drive
the controller) and ``trajectory.png`` (the last trial, with ghosts where the winner changed).

Choices (measured, research/TORCHRL.md): no ``StepCounter`` / ``RewardSum`` / ``InitTracker``
transforms (the trial record already counts steps and sums rewards, and each transform costs
tens of us a step); ``track_traj_ids=False`` and ``return_same_td=True`` (each transition is
consumed before the next step), which make the Collector ~30% and ~20% cheaper per step. The
loop calls ``loss.update`` (numbers) rather than ``loss(td)`` (a TensorDict of diagnostics).
"""

from __future__ import annotations

import argparse
import csv
import math
import random
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

from symrl import ENV_ID
from symrl.learner.config import RunConfig, config_from_dict, config_to_dict, load_config

__all__ = [
    "TrainResult",
    "train",
    "evaluate",
    "make_env",
    "make_policy",
    "load_checkpoint",
    "save_checkpoint",
    "train_command",
    "evaluate_command",
]

# Keys of a trial record that are scalars (the CSV and TensorBoard columns); `path` and
# `ghosts` are lists of points.
_TRIAL_SCALARS = (
    "trial", "steps", "total_reinforcement", "collisions", "shielded", "reached_goal", "neurons",
    "temperature", "path_length", "wall_time",
)  # fmt: skip


@dataclass
class TrainResult:
    """What :func:`train` returns."""

    config: RunConfig
    trials: list[dict[str, Any]]
    policy: Any
    logdir: Path | None = None
    timings: dict[str, float] = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# Factories


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (the env is seeded through the TorchRL wrapper)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def make_env(config: RunConfig):
    """The world as a TorchRL ``GymEnv`` that also reads ``collision``, ``reached_goal`` and
    ``true_pose`` from ``info`` (for the trial table and the path)."""
    from torchrl.data import Unbounded

    from symrl.learner.gym_io import InfoReader, SymrlGymEnv

    ec = config.env
    # a GymEnv whose per-step readers skip the generic encoding (same tensors, ~90 us cheaper)
    env = SymrlGymEnv(
        ENV_ID, map=ec.map, noise=ec.noise, max_actions=ec.max_actions, robot=ec.robot()
    )
    info_spec = {
        "collision": Unbounded(shape=(), dtype=torch.bool),
        "reached_goal": Unbounded(shape=(), dtype=torch.bool),
        "true_pose": Unbounded(shape=(3,), dtype=torch.float64),
    }
    env.set_info_dict_reader(InfoReader(info_spec))  # ~40 us a step cheaper than the default
    return env


def make_policy(config: RunConfig, world=None, robot=None):
    """The controller for ``config`` (fresh: no neurons, temperature T0)."""
    from symrl.knowledge.reflex import FuzzyReflex
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.world.robot import RobotConfig

    if robot is None:  # the robot the config describes (sensor range, thresholds of r(state))
        robot = RobotConfig.from_dict(config.env.robot())
    return MixtureOfExpertsPolicy(
        config.learner,
        world=world or config.env.map,
        robot=robot,
        reflex=FuzzyReflex(config.reflex),
        seed=config.run.seed,
    )


# ---------------------------------------------------------------------------------------------
# One trial's bookkeeping


class TrialRecorder:
    """Accumulates one trial from the collector's transitions (reads a few columns per step)."""

    def __init__(self, expert_names: tuple[str, ...]) -> None:
        self.expert_names = expert_names
        self.reset()

    def reset(self) -> None:
        self.steps = 0
        self.total = 0.0
        self.collisions = 0
        self.shielded = 0
        self.td_error_abs = 0.0
        self.path: list[tuple[float, float]] = []
        self.ghosts: list[tuple[float, float]] = []
        self._last_winner: tuple[int, int] | None = None
        self.started = time.perf_counter()

    def step(self, td) -> bool:
        """Record one transition (batch [1]); return True when the trial has ended."""
        if not self.path:
            x, y, _ = td.get("true_pose")[0].tolist()
            self.path.append((x, y))
        winner = (td.get("expert").item(), td.get("winner").item())
        if winner != self._last_winner:  # a "ghost" where the controller toggles neurons
            self.ghosts.append(self.path[-1])
            self._last_winner = winner
        nxt = td.get("next")
        self.steps += 1
        self.total += nxt.get("reward").item()
        self.collisions += int(nxt.get("collision").item())
        self.shielded += int(td.get("shielded").item())
        x, y, _ = nxt.get("true_pose")[0].tolist()
        self.path.append((x, y))
        self.reached = nxt.get("reached_goal").item()
        return nxt.get("done").item()

    def finish(self, trial: int, policy) -> dict[str, Any]:
        xy = np.asarray(self.path)
        record: dict[str, Any] = {
            "trial": trial,
            "steps": self.steps,
            "total_reinforcement": self.total,
            "collisions": self.collisions,
            "reached_goal": self.reached,
            "neurons": policy.total_neurons(),
            "shielded": self.shielded,
        }
        for name, n in policy.neurons().items():
            record[f"neurons_{name}"] = n
        record["temperature"] = float(policy.temperature)
        record["mean_abs_td_error"] = self.td_error_abs / max(self.steps, 1)
        record["path_length"] = float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())
        record["wall_time"] = time.perf_counter() - self.started
        record["path"] = self.path
        record["ghosts"] = self.ghosts
        return record


# ---------------------------------------------------------------------------------------------
# Training


def train(
    config: RunConfig, logdir: str | Path | None = None, progress: bool = True
) -> TrainResult:
    """Train ``config.run.trials`` trials online; log into ``logdir`` if given."""
    from torchrl.collectors import Collector
    from tqdm.auto import tqdm

    from symrl.learner.loss import TeseoLoss

    n_trials, seed = config.run.trials, config.run.seed
    seed_everything(seed)
    env = make_env(config)
    env.set_seed(seed)
    base = env._env.unwrapped  # the Hailu2001Env (world, robot) behind the TorchRL wrapper
    policy = make_policy(config, world=base.world, robot=base.robot)
    loss = TeseoLoss(policy)
    collector = Collector(
        env,
        policy,
        frames_per_batch=1,
        total_frames=n_trials * config.env.max_actions,  # an upper bound: we stop at N trials
        reset_at_each_iter=False,
        track_traj_ids=False,  # ~30% cheaper per step; trials are delimited by "done"
        return_same_td=True,  # no copy per step: each transition is consumed before the next
        auto_register_policy_transforms=False,
    )
    # TorchRL 0.14 scans every key of every batch for private ("_...") keys to drop; ours has
    # none (the preallocated batch holds the specs' keys), and the scan costs ~100 us a step.
    collector._exclude_private_keys = False
    logger = _make_logger(config, logdir) if logdir is not None else None
    recorder = TrialRecorder(policy.expert_names)
    trials: list[dict[str, Any]] = []
    bar = tqdm(total=n_trials, desc=config.recipe, unit="trial", disable=not progress)
    started, cpu_started = time.perf_counter(), time.process_time()
    frames = 0
    try:
        for td in collector:
            # The per-step TESEO update; ``loss(td)`` returns the same as a TensorDict of
            # diagnostics, but building one costs ~30 us a step, so the loop takes the numbers.
            delta, _ = loss.update(td)
            recorder.td_error_abs += abs(delta)
            frames += 1
            if not recorder.step(td):
                continue
            record = recorder.finish(len(trials) + 1, policy)
            record.update(loss.end_trial(record))  # replace actions, cool the temperature
            trials.append(record)
            bar.update(1)
            bar.set_postfix(steps=record["steps"], total=f"{record['total_reinforcement']:.2f}")
            if logger is not None:
                _log_trial(logger, config, policy, record, last=len(trials) == n_trials)
            recorder.reset()
            if len(trials) >= n_trials:
                break
    finally:
        bar.close()
        collector.shutdown()
        env.close()
    elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    result = TrainResult(
        config, trials, policy, Path(logdir) if logdir is not None else None,
        timings={
            "seconds": elapsed,
            "cpu_seconds": cpu,  # this process only: robust to other jobs on the machine
            "frames": frames,
            "steps_per_second": frames / elapsed,
        },
    )  # fmt: skip
    if logdir is not None:
        _write_outputs(result)
    return result


# ---------------------------------------------------------------------------------------------
# Evaluation (greedy, read-only)


def evaluate(
    checkpoint_or_policy: str | Path | Any,
    start: tuple[float, float, float] | None = None,
    seed: int = 0,
    noise: bool = True,
    config: RunConfig | None = None,
    world: Any = None,
) -> dict[str, Any]:
    """Drive one greedy trial (exploration type DETERMINISTIC) and return its record.

    ``world``: drive in another map (e.g. ``WorldMap.with_obstacle``) than the one it learned in.
    """
    import gymnasium
    from tensordict import TensorDict
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    if isinstance(checkpoint_or_policy, (str, Path)):
        policy, config = load_checkpoint(checkpoint_or_policy)
    else:
        policy = checkpoint_or_policy
        config = config or RunConfig(learner=policy.config)
    env = gymnasium.make(
        ENV_ID,
        map=policy.world if world is None else world,
        noise=noise,
        max_actions=config.env.max_actions,
        robot=config.env.robot(),
    )
    options = None if start is None else {"pose": tuple(float(v) for v in start)}
    obs, info = env.reset(seed=seed, options=options)
    recorder = TrialRecorder(policy.expert_names)
    recorder.path.append(tuple(float(v) for v in info["true_pose"][:2]))
    done = False
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        while not done:
            td = TensorDict({k: torch.as_tensor(v) for k, v in obs.items()}, [])
            policy(td)
            winner = (int(td.get("expert")), int(td.get("winner")))
            if winner != recorder._last_winner:
                recorder.ghosts.append(recorder.path[-1])
                recorder._last_winner = winner
            obs, reward, terminated, truncated, info = env.step(td.get("action").numpy())
            recorder.steps += 1
            recorder.total += float(reward)
            recorder.collisions += int(info["collision"])
            recorder.shielded += int(td.get("shielded"))
            recorder.path.append(tuple(float(v) for v in info["true_pose"][:2]))
            recorder.reached = bool(info["reached_goal"])
            done = terminated or truncated
    env.close()
    record = recorder.finish(0, policy)
    record.update(start=None if start is None else list(start), seed=seed, noise=noise)
    return record


# ---------------------------------------------------------------------------------------------
# Files: checkpoint, config, CSV, figures, TensorBoard


def save_checkpoint(path: str | Path, policy, config: RunConfig) -> None:
    """Everything needed to rebuild and drive the controller: config + state dict (with sizes)."""
    torch.save(
        {"format": 1, "config": config_to_dict(config), "state_dict": policy.state_dict()}, path
    )


def load_checkpoint(path: str | Path):
    """Rebuild ``(policy, config)`` from :func:`save_checkpoint`."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint {str(path)!r}: no such file")
    data = torch.load(path, map_location="cpu", weights_only=True)  # tensors + plain config
    if not isinstance(data, dict) or "config" not in data or "state_dict" not in data:
        raise ValueError(f"checkpoint {str(path)!r}: not written by symrl train")
    cfg = dict(data["config"])
    config = config_from_dict(cfg, recipe=cfg.get("recipe", "checkpoint"))
    policy = make_policy(config)
    policy.load_state_dict(data["state_dict"])
    return policy, config


def _make_logger(config: RunConfig, logdir: str | Path):
    from torchrl.record.loggers import TensorboardLogger

    logdir = Path(logdir)
    logdir.mkdir(parents=True, exist_ok=True)
    logger = TensorboardLogger(exp_name="tb", log_dir=str(logdir))
    rows = ["| key | value |", "| --- | --- |"]
    for section, values in config_to_dict(config).items():
        if isinstance(values, dict):
            rows += [f"| {section}.{k} | {v} |" for k, v in values.items()]
        else:
            rows.append(f"| {section} | {values} |")
    logger.experiment.add_text("config", "\n".join(rows), 0)
    return logger


def _log_trial(logger, config: RunConfig, policy, record: dict[str, Any], last: bool) -> None:
    n = record["trial"]
    logger.log_scalar("trial/steps", record["steps"], step=n)
    logger.log_scalar("trial/total_reinforcement", record["total_reinforcement"], step=n)
    logger.log_scalar("trial/collisions", record["collisions"], step=n)
    logger.log_scalar("trial/shielded", record["shielded"], step=n)
    logger.log_scalar("trial/reached_goal", float(record["reached_goal"]), step=n)
    logger.log_scalar("network/neurons", record["neurons"], step=n)
    for name in policy.expert_names:
        logger.log_scalar(f"network/neurons/{name}", record[f"neurons_{name}"], step=n)
    logger.log_scalar("explore/temperature", record["temperature"], step=n)
    logger.log_scalar("learn/mean_abs_td_error", record["mean_abs_td_error"], step=n)
    logger.log_scalar("learn/replaced_actions", record.get("replaced", 0), step=n)
    if last or n == 1 or n % config.run.image_every == 0:
        fig = trajectory_figure(policy.world, record)
        logger.experiment.add_figure("trial/trajectory", fig, global_step=n, close=True)


def trajectory_figure(world, record: dict[str, Any], title: str | None = None):
    """The map, the trial's true path and its ghosts (points where the winner changed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from symrl.world.render import draw_path, draw_world

    fig, ax = plt.subplots(figsize=(5.5, 5))
    draw_world(ax, world)
    draw_path(ax, record["path"], label="path")
    if record.get("ghosts"):
        g = np.asarray(record["ghosts"])
        ax.scatter(g[:, 0], g[:, 1], s=22, facecolors="none", edgecolors="tab:purple",
                   label="ghosts", zorder=4)  # fmt: skip
    ax.set_title(
        title
        or f"trial {record['trial']}: {record['steps']} actions, "
        f"total {record['total_reinforcement']:.2f}"
    )
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


def _write_outputs(result: TrainResult) -> None:
    import matplotlib.pyplot as plt

    out = result.logdir
    assert out is not None
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yaml").write_text(yaml.safe_dump(config_to_dict(result.config), sort_keys=False))
    write_trials_csv(out / "trials.csv", result.trials)
    save_checkpoint(out / "checkpoint.pt", result.policy, result.config)
    if result.trials:
        fig = trajectory_figure(result.policy.world, result.trials[-1])
        fig.savefig(out / "trajectory.png", dpi=120)
        plt.close(fig)


def write_trials_csv(path: Path, trials: list[dict[str, Any]]) -> None:
    """One row per trial, every scalar column (paths and ghosts left out). Columns are the union
    over trials in first-seen order (a variant may add keys only in some trials); gaps stay empty.
    """
    if not trials:
        return
    columns: dict[str, None] = {}
    for row in trials:
        for k, v in row.items():
            if not isinstance(v, (list, tuple, dict)):
                columns.setdefault(k)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(columns), extrasaction="ignore")
        writer.writeheader()
        for row in trials:
            writer.writerow({k: _fmt(row[k]) for k in columns if k in row})


def _fmt(value: Any) -> Any:
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return value


# ---------------------------------------------------------------------------------------------
# Command-line handlers (parsing lives in symrl/cli.py)


def train_command(args: argparse.Namespace) -> int:
    overrides = list(args.overrides or [])
    if args.trials is not None:
        overrides.append(f"run.trials={args.trials}")
    if args.seed is not None:
        overrides.append(f"run.seed={args.seed}")
    config = load_config(args.recipe, overrides)
    logdir = args.logdir or (
        f"runs/{config.recipe}__s{config.run.seed}__{time.strftime('%Y%m%d-%H%M%S')}"
    )
    result = train(config, logdir=logdir, progress=True)
    trials = result.trials
    last = trials[-5:]
    print(
        f"{config.recipe}: {len(trials)} trials, {result.timings['steps_per_second']:.0f} steps/s; "
        f"last trial {trials[-1]['steps']} actions, total {trials[-1]['total_reinforcement']:.2f}, "
        f"{trials[-1]['neurons']} neurons; last-{len(last)} mean "
        f"{np.mean([t['steps'] for t in last]):.1f} actions, "
        f"total {np.mean([t['total_reinforcement'] for t in last]):.2f}, "
        f"goal {sum(t['reached_goal'] for t in trials)}/{len(trials)}"
    )
    print(f"wrote {logdir}/ (trials.csv, config.yaml, checkpoint.pt, trajectory.png, tb/)")
    return 0


def evaluate_command(args: argparse.Namespace) -> int:
    import matplotlib.pyplot as plt

    policy, config = load_checkpoint(args.checkpoint)
    record = evaluate(policy, start=args.start, seed=args.seed, config=config)
    out = Path(args.out) if args.out else Path(args.checkpoint).parent
    out.mkdir(parents=True, exist_ok=True)
    fig = trajectory_figure(
        policy.world, record,
        title=f"greedy: {record['steps']} actions, total {record['total_reinforcement']:.2f}",
    )  # fmt: skip
    fig.savefig(out / "evaluate.png", dpi=120)
    plt.close(fig)
    print(
        f"greedy trial: {record['steps']} actions, total {record['total_reinforcement']:.2f}, "
        f"{record['collisions']} collisions, reached goal {record['reached_goal']}, "
        f"path {record['path_length']:.2f} m"
    )
    print(f"wrote {out / 'evaluate.png'}")
    return 0
