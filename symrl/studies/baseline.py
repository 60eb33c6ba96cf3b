"""One baseline run (the recipes ``sac`` and ``ppo``, trained by ``symrl train``): its env,
agent and run folder around the one training loop, :class:`symrl.loop.TrainingLoop`.

A baseline is an *algorithm* (:mod:`symrl.studies.sac`, :mod:`symrl.studies.ppo`): a TorchRL
actor that writes ``control`` in [-1, 1] and an update that learns from batches of transitions,
made an :class:`symrl.agent.Agent` with the priors' action
(:class:`symrl.studies.baseline_agent.BaselineAgent`). The config's ``baseline`` section
names the algorithm, its priors and hyper-parameters; everything else is shared and is
symrl's own:

    env       = TransformedEnv(BatchedWorldEnv(B robots), PriorObservation)  observation [+priors]
    collector = StepCollector(env, agent.policy)     act: control -> action (residual: reflex + c)
    TrainingLoop(collector, agent, SharedTrials(run.trials), TrialRecorder(B)).run()
        every step: agent.learn (observe); the trial table; ended trials -> RunWriter.trial
        (trials.csv, TensorBoard); checkpoints every ``checkpoint_every`` trials

The world is the recipe's (``env``, and with the residual ``reflex`` and ``shield.margin``),
cut to what the recipe tells the robot (``knowledge``: the region one-hot needs the region
rules). A *trial* is one episode; with B robots the trials are numbered in the order they end
(robots in index order within a step). A run is deterministic given its seed: robot k's world
draws from ``seed`` (k = 0) or ``seed * 1000 + k``, the networks and their sampling from
``torch.manual_seed(seed)``. A run of N trials is the first N trials of a longer run with the
same seed (nothing depends on the budget).

A run folder is a symrl run folder (:class:`symrl.runs.RunWriter`): ``config.yaml`` (the
settings the baseline reads), ``trials.csv`` (the trial table's base columns; the paper
learner's own ones -- neurons, temperature, ... -- stay empty), ``tb/`` and ``checkpoint.pt``,
which ``symrl evaluate`` drives (:func:`load_baseline`) and ``symrl train --resume`` goes on
from (:func:`load_baseline_resume`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from symrl.learner.config import RunConfig
from symrl.studies.baseline_agent import Algorithm, BaselineAgent, algorithms
from symrl.studies.baseline_checkpoint import (
    CHECKPOINT_KIND,
    SNAPSHOT_FORMAT,
    BaselineController,
    load_baseline,
    load_baseline_resume,
    save_baseline,
)
from symrl.studies.baseline_env import make_env, robot_seeds
from symrl.studies.priors import PriorAction, priors_of

__all__ = [
    "Algorithm",
    "make_env",
    "robot_seeds",
    "train_baseline",
    "summarise",
    "first_reliable",
    "BaselineController",
    "load_baseline",
    "load_baseline_resume",
    "save_baseline",
    "parse_seeds",
    "CHECKPOINT_KIND",
    "SNAPSHOT_FORMAT",
]

RELIABLE_WINDOW, RELIABLE_LEVEL = 20, 0.8


# ---------------------------------------------------------------------------------------------
# Statistics of a trial table


def first_reliable(
    reached: Sequence[bool], window: int = RELIABLE_WINDOW, level: float = RELIABLE_LEVEL
) -> int | None:
    """First trial (1-based) from which ``window`` trials reach the goal at least ``level`` of
    the time (trials k .. k + window - 1); None if no full window does."""
    r = np.asarray(reached, dtype=float)
    if len(r) < window:
        return None
    rate = np.convolve(r, np.ones(window), "valid") / window
    hits = np.nonzero(rate >= level - 1e-12)[0]
    return int(hits[0] + 1) if len(hits) else None


def summarise(rows: Sequence[dict[str, Any]], budget: int) -> dict[str, Any]:
    """The comparison's numbers for the first ``budget`` trials of a run: first success, first
    reliable trial, last-5 actions and total reinforcement, collisions, env steps."""
    rows = list(rows)[:budget]
    reached = [bool(r["reached_goal"]) for r in rows]
    last = rows[-5:]
    return {
        "trials": len(rows),
        "first_success": next((i + 1 for i, ok in enumerate(reached) if ok), None),
        "first_reliable": first_reliable(reached),
        "successes": int(sum(reached)),
        "last5_actions": float(np.mean([r["steps"] for r in last])) if last else math.nan,
        "last5_total": (
            float(np.mean([r["total_reinforcement"] for r in last])) if last else math.nan
        ),
        "collisions": int(sum(int(r["collisions"]) for r in rows)),
        "env_steps": int(sum(int(r["steps"]) for r in rows)),
    }


# ---------------------------------------------------------------------------------------------
# One run


def train_baseline(
    config: RunConfig,
    logdir: str | Path | None = None,
    *,
    world: Any = None,
    overwrite: bool = False,
    resume: dict[str, Any] | None = None,
    checkpoint_every: int = 50,
    progress: bool = True,
    stop: Callable[[], bool] | None = None,
) -> Any:
    """Train the baseline of ``config`` (``baseline.algorithm``) for ``run.trials`` trials with
    seed ``run.seed``; write its run folder ``logdir`` (if given).

    The checkpoint holds the whole run state, written every ``checkpoint_every`` trials, when
    ``stop()`` turns true (checked between two steps: the run stops there) and at the end;
    ``resume`` (the state :func:`load_baseline_resume` read from ``logdir``) goes on from it,
    and the trial table is the uninterrupted run's. Returns a :class:`symrl.train.TrainResult`
    (no policy: the controller is in the checkpoint) whose timings hold the wall time and
    robot-steps at the 20th trial too. Runs on one torch thread (small networks: as fast, and it
    shares the machine)."""
    if config.baseline.algorithm is None:
        raise ValueError(
            f"recipe {config.recipe!r}: baseline.algorithm is null; train_baseline trains a "
            "baseline (the recipes sac and ppo)"
        )
    if resume is not None and logdir is None:
        raise ValueError("resume: needs the run folder (logdir)")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _train_baseline(
            config, logdir, world, overwrite, resume, max(1, int(checkpoint_every)), progress, stop
        )
    finally:
        torch.set_num_threads(threads)


def _train_baseline(
    config: RunConfig,
    logdir: str | Path | None,
    world: Any,
    overwrite: bool,
    state: dict[str, Any] | None,
    checkpoint_every: int,
    progress: bool,
    stop: Callable[[], bool] | None,
) -> Any:
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from symrl.loop import TrainingLoop

    seed = config.run.seed
    torch.manual_seed(seed)
    run = _Run(config, world, state)
    run.open(logdir, overwrite, checkpoint_every)
    label = f"{config.baseline.algorithm} {priors_of(config).label()} seed {seed}"
    run.loop = TrainingLoop(
        run.collector,
        run.agent,
        run.table,
        run.recorder,
        on_trial=run.take,
        on_boundary=run.boundary,
        stop=stop,
        progress=progress,
        bar={"desc": label, "mininterval": 5},
        frames=int(state["frames"]) if state is not None else 0,
    )
    try:
        with set_exploration_type(ExplorationType.RANDOM):
            stopped = run.loop.run()
        run.save()
        if run.writer is not None and not stopped:
            run.writer.finish(None, seed)
    finally:
        run.close()
    return run.result(stopped)


class _Run:
    """One baseline run's parts: env, agent, collector, trial recorder and table (resumed
    from ``state``), the run folder's writer and checkpoints, its clock and the time and
    robot-steps at its 20th trial."""

    def __init__(self, config: RunConfig, world: Any, state: dict[str, Any] | None) -> None:
        from torchrl.envs.utils import ExplorationType

        from symrl.collector import StepCollector
        from symrl.loop import SharedTrials
        from symrl.recorder import TrialRecorder
        from symrl.world.worldmap import load_map

        b = config.baseline
        assert b.algorithm is not None
        self.config, self.state = config, state
        self.t0, self.cpu0 = time.perf_counter(), time.process_time()
        self.world = world if world is not None else load_map(config.env.map)
        envs = b.robots
        env = make_env(config, robot_seeds(config.run.seed, envs), self.world)
        self.n_obs = env.observation_spec["observation"].shape[-1]
        algorithm_cls = algorithms()[b.algorithm]
        self.agent = BaselineAgent(
            algorithm_cls(b.hyper(), self.n_obs, envs), PriorAction(priors_of(config), config)
        )
        self.collector = StepCollector(
            env, self.agent.policy, exploration_type=ExplorationType.RANDOM
        )
        self.recorder = TrialRecorder(envs)
        self.table = SharedTrials(config.run.trials)
        self.writer: Any = None
        self.loop: Any = None
        self.at20: tuple[float, int] | None = None

    def open(self, logdir: str | Path | None, overwrite: bool, checkpoint_every: int) -> None:
        """The run folder (if any), then the parts put into the resumed state."""
        from symrl.runs import BASE_COLUMNS, RunWriter

        state, episodes = self.state, self.table.total
        self.every = checkpoint_every
        if logdir is not None:
            self.writer = RunWriter(
                logdir,
                self.config,
                self.world,
                overwrite=overwrite,
                resume_rows=state["trials"] if state is not None else None,
                columns=list(BASE_COLUMNS),
                flag="--resume" if state is not None else "--logdir",
            )
        if state is not None:
            self.table = _restore(state, self.agent, self.collector, self.recorder, episodes)
            self.at20 = tuple(state["at20"]) if state["at20"] is not None else None

    def elapsed(self) -> tuple[float, float]:
        """Wall and CPU seconds of the run, those before its resume included."""
        before = self.state or {"wall_s": 0.0, "cpu_s": 0.0}
        return (
            before["wall_s"] + time.perf_counter() - self.t0,
            before["cpu_s"] + time.process_time() - self.cpu0,
        )

    def take(self, b: int, record: dict[str, Any]) -> None:
        """A row of the table: to the run folder; the 20th trial's time and robot-steps."""
        rows, episodes = self.table.rows, self.table.total
        if self.writer is not None:
            self.writer.trial(record, last=len(rows) == episodes)
        if len(rows) == min(20, episodes) and self.at20 is None:
            self.at20 = (round(self.elapsed()[0], 1), self.loop.frames)

    def boundary(self, added: list[tuple[int, dict[str, Any]]]) -> None:
        """A checkpoint when the table passed a multiple of ``checkpoint_every`` rows."""
        done = len(self.table.rows)
        if done // self.every > (done - len(added)) // self.every:
            self.save()

    def save(self) -> None:
        """The checkpoint with the run state (nothing without a run folder)."""
        if self.writer is None:
            return
        wall, cpu = self.elapsed()
        run_state = {
            "format": SNAPSHOT_FORMAT,
            **_loop_state(self.agent, self.collector, self.recorder, self.table),
            "frames": self.loop.frames,
            "wall_s": wall,
            "cpu_s": cpu,
            "at20": list(self.at20) if self.at20 is not None else None,
        }
        save_baseline(
            self.writer.dir / "checkpoint.pt",
            self.agent.algorithm,
            self.config,
            self.world,
            self.n_obs,
            resume=run_state,
        )

    def close(self) -> None:
        """The env closed, the run folder flushed and let go."""
        self.collector.shutdown()
        if self.writer is not None:
            self.writer.close()
            self.writer.release()  # the loop and the run refer to each other: not left to gc

    def result(self, stopped: bool) -> Any:
        """The run as a :class:`symrl.train.TrainResult` (no policy)."""
        from symrl.train import TrainResult

        wall, cpu = self.elapsed()
        frames = self.loop.frames
        at20 = self.at20
        timings = {
            "seconds": wall,
            "cpu_seconds": cpu,
            "frames": frames,
            "robots": self.recorder.batch,
            "steps_per_second": frames / max(wall, 1e-9),
            "stopped": int(stopped),
            "at20_seconds": at20[0] if at20 else math.nan,
            "at20_frames": at20[1] if at20 else math.nan,
        }
        return TrainResult(
            self.config, self.config.run.seed, self.table.rows, None, timings, self.world
        )


def _loop_state(agent: BaselineAgent, collector: Any, recorder: Any, table: Any) -> dict[str, Any]:
    """The run state's entries of the loop's parts: trial rows (taken and pending), the
    agent, the robots' worlds and the observation the next step acts on, the trials in
    progress, torch's generator."""
    collected = collector.state_dict()
    return {
        "trials": table.rows,
        "pending": table.pending,
        "agent": agent.state_dict(),
        "env": collected["env_state_dict"],
        "recorder": recorder.state(),
        "torch_rng": torch.get_rng_state(),
        "td": collected["carrier"],
    }


def _restore(
    state: dict[str, Any], agent: BaselineAgent, collector: Any, recorder: Any, episodes: int
) -> Any:
    """Put the fresh parts of a run into ``state`` (:func:`_loop_state`); its trial table."""
    from symrl.loop import SharedTrials

    agent.load_state_dict(state["agent"])
    collector.load_state_dict(
        {"env_state_dict": state["env"], "carrier": state["td"], "frames": 0, "iter": -1}
    )
    recorder.load_state(state["recorder"])
    torch.set_rng_state(state["torch_rng"])
    return SharedTrials(episodes, state["trials"], state["pending"])


# ---------------------------------------------------------------------------------------------
# Seeds of ``symrl baseline``


MAX_SEEDS = 10_000
"""Most seeds (runs) one baseline command trains."""


def parse_seeds(text: str) -> list[int]:
    """``100-104`` and/or ``100,105``; one-line ValueError naming --seeds otherwise."""
    seeds: list[int] = []
    try:
        for part in str(text).split(","):
            part = part.strip()
            if "-" in part[1:]:
                lo, hi = (int(p) for p in part.split("-", 1))
                if hi < lo:
                    raise ValueError
                if hi - lo + 1 + len(seeds) > MAX_SEEDS:
                    raise OverflowError
                seeds += range(lo, hi + 1)
            elif part:
                seeds.append(int(part))
    except OverflowError:
        raise ValueError(f"--seeds {text!r}: more than {MAX_SEEDS} seeds") from None
    except ValueError:
        raise ValueError(
            f"--seeds {text!r}: expected seeds as a range 100-104 and/or a list 100,105"
        ) from None
    if not seeds or min(seeds) < 0:
        raise ValueError(f"--seeds {text!r}: give at least one seed, each >= 0")
    return seeds
