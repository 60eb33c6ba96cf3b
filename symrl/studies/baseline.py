"""One baseline run (``symrl baseline {ppo,sac}``; the command is
:mod:`symrl.studies.baseline_command`): its env, agent and run folder around the one training
loop, :class:`symrl.loop.TrainingLoop`.

A baseline is an *algorithm* (:mod:`symrl.studies.sac`, :mod:`symrl.studies.ppo`): a TorchRL
actor that writes ``control`` in [-1, 1] and an update that learns from batches of transitions,
made an :class:`symrl.agent.Agent` with the priors' action
(:class:`symrl.studies.baseline_agent.BaselineAgent`). Everything else is shared and is
symrl's own:

    env       = TransformedEnv(BatchedWorldEnv(B robots), PriorObservation)  observation [+priors]
    collector = StepCollector(env, agent.policy)     act: control -> action (residual: reflex + c)
    TrainingLoop(collector, agent, SharedTrials(episodes), TrialRecorder(B)).run()
        every step: agent.learn (observe); the trial table; ended trials -> RunWriter.trial
        (trials.csv, TensorBoard); checkpoints every ``checkpoint_every`` trials

The world is the paper's (``paper`` recipe's env, reflex and shield sections: the same robot,
noise on, 200-action trials, reward f1 + f2). A *trial* is one episode; with B robots the
trials are numbered in the order they end (robots in index order within a step). A run is
deterministic given its seed: robot k's world draws from ``seed`` (k = 0) or ``seed * 1000 + k``,
the networks and their sampling from ``torch.manual_seed(seed)``. A run of N trials is the
first N trials of a longer run with the same seed (nothing depends on the budget).

A run folder is a symrl run folder (:class:`symrl.runs.RunWriter`): ``config.yaml`` (the
settings the baseline uses), ``trials.csv`` (the trial table's base columns; the paper
learner's own ones -- neurons, temperature, ... -- stay empty), ``tb/`` and ``checkpoint.pt``,
which ``symrl evaluate`` drives (:func:`load_baseline`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch

from symrl.studies.baseline_agent import Algorithm, BaselineAgent, algorithms
from symrl.studies.baseline_checkpoint import (
    CHECKPOINT_KIND,
    SNAPSHOT_FORMAT,
    BaselineController,
    knowledge_of,
    load_baseline,
    load_run_state,
    save_baseline,
)
from symrl.studies.baseline_env import make_env, robot_seeds, run_config
from symrl.studies.priors import PriorAction, Priors

__all__ = [
    "Algorithm",
    "make_env",
    "run_config",
    "robot_seeds",
    "train_baseline",
    "summarise",
    "first_reliable",
    "BaselineController",
    "load_baseline",
    "load_run_state",
    "save_baseline",
    "knowledge_of",
    "baseline_settings",
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
    algorithm: str,
    seed: int = 100,
    episodes: int = 20,
    priors: Priors | None = None,
    map: str = "hailu2001",
    envs: int | None = None,
    logdir: str | Path | None = None,
    progress: bool = True,
    overwrite: bool = False,
    resume: bool = False,
    checkpoint_every: int = 50,
    stop: Callable[[], bool] | None = None,
    **settings: Any,
) -> dict[str, Any]:
    """Train one baseline for ``episodes`` trials; write its run folder ``logdir`` (if given).

    ``settings`` override the algorithm's defaults (``SACConfig`` / ``PPOConfig`` fields).
    The checkpoint holds the whole run state, written every ``checkpoint_every`` trials, when
    ``stop()`` turns true (checked between two steps: the run stops there) and at the end;
    ``resume`` goes on from the run in ``logdir`` (to a budget at least its own), and the
    trial table is the uninterrupted run's. Returns the trial rows, the summaries at 20 trials
    and at the end, and timings. Runs on one torch thread (small networks: as fast, and it
    shares the machine)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _train_baseline(
            algorithm,
            seed,
            episodes,
            priors,
            map,
            envs,
            logdir,
            progress,
            overwrite,
            resume,
            checkpoint_every,
            stop,
            settings,
        )
    finally:
        torch.set_num_threads(threads)


def _train_baseline(
    algorithm: str,
    seed: int,
    episodes: int,
    priors: Priors | None,
    map: str,
    envs: int | None,
    logdir: str | Path | None,
    progress: bool,
    overwrite: bool,
    resume: bool,
    checkpoint_every: int,
    stop: Callable[[], bool] | None,
    settings: dict[str, Any],
) -> dict[str, Any]:
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from symrl.loop import TrainingLoop

    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"--episodes {episodes!r}: must be an integer >= 1")
    if checkpoint_every < 1:
        raise ValueError(f"--checkpoint-every {checkpoint_every!r}: must be >= 1")
    priors = priors or Priors()
    algorithm_cls, cfg_cls = algorithms()[algorithm]
    cfg = cfg_cls(**settings)
    envs = cfg.envs if envs is None else envs
    if isinstance(envs, bool) or not isinstance(envs, int) or envs < 1:
        raise ValueError(f"--envs {envs!r}: must be an integer >= 1")
    run_settings = baseline_settings(algorithm, priors, seed, envs, cfg)
    config = run_config(map, seed, episodes)
    state = None
    if resume:
        if logdir is None:
            raise ValueError("resume: needs the run folder (logdir)")
        state = load_run_state(logdir, run_settings, episodes, knowledge_of(config, priors))
    torch.manual_seed(seed)
    run = _Run(algorithm, algorithm_cls, cfg, priors, config, seed, envs, state)
    run.open(logdir, overwrite, run_settings, checkpoint_every)
    run.loop = TrainingLoop(
        run.collector,
        run.agent,
        run.table,
        run.recorder,
        on_trial=run.take,
        on_boundary=run.boundary,
        stop=stop,
        progress=progress,
        bar={"desc": f"{algorithm} {priors.label()} seed {seed}", "mininterval": 5},
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
    return _result(algorithm, priors, seed, map, envs, cfg, run, stopped)


_algorithms = algorithms  # the name benchmarks/bench_baselines.py uses


class _Run:
    """One baseline run's parts: env, agent, collector, trial recorder and table (resumed
    from ``state``), the run folder's writer and checkpoints, its clock and the time and
    robot-steps at its 20th trial."""

    def __init__(
        self,
        algorithm: str,
        algorithm_cls: Any,
        cfg: Any,
        priors: Priors,
        config: Any,
        seed: int,
        envs: int,
        state: dict[str, Any] | None,
    ) -> None:
        from torchrl.envs.utils import ExplorationType

        from symrl.collector import StepCollector
        from symrl.loop import SharedTrials
        from symrl.recorder import TrialRecorder
        from symrl.world.worldmap import load_map

        self.algorithm, self.priors, self.config, self.seed = algorithm, priors, config, seed
        self.state = state
        self.t0, self.cpu0 = time.perf_counter(), time.process_time()
        self.world = load_map(config.env.map)
        env = make_env(config, priors, robot_seeds(seed, envs), self.world)
        self.n_obs = env.observation_spec["observation"].shape[-1]
        self.agent = BaselineAgent(
            algorithm_cls(cfg, self.n_obs, envs), PriorAction(priors, config)
        )
        self.collector = StepCollector(
            env, self.agent.policy, exploration_type=ExplorationType.RANDOM
        )
        self.recorder = TrialRecorder(envs)
        self.table = SharedTrials(config.run.trials)
        self.writer: Any = None
        self.loop: Any = None
        self.at20: tuple[float, int] | None = None

    def open(
        self,
        logdir: str | Path | None,
        overwrite: bool,
        run_settings: dict[str, Any],
        checkpoint_every: int,
    ) -> None:
        """The run folder (if any), then the parts put into the resumed state."""
        from symrl.runs import BASE_COLUMNS, RunWriter

        state, episodes = self.state, self.table.total
        self.run_settings, self.every = run_settings, checkpoint_every
        if logdir is not None:
            self.writer = RunWriter(
                logdir,
                self.config,
                self.world,
                overwrite=overwrite,
                resume_rows=state["rows"] if state is not None else None,
                columns=list(BASE_COLUMNS),
                settings={**run_settings, "episodes": episodes, **knowledge_of(self.config)},
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
            "settings": self.run_settings,
            **_loop_state(self.agent, self.collector, self.recorder, self.table),
            "frames": self.loop.frames,
            "wall_s": wall,
            "cpu_s": cpu,
            "at20": list(self.at20) if self.at20 is not None else None,
        }
        save_baseline(
            self.writer.dir / "checkpoint.pt",
            self.algorithm,
            self.agent.algorithm,
            self.priors,
            self.config,
            self.world,
            self.seed,
            self.n_obs,
            resume=run_state,
        )

    def close(self) -> None:
        """The env closed, the run folder flushed and let go."""
        self.collector.shutdown()
        if self.writer is not None:
            self.writer.close()
            self.writer.release()  # the loop and the run refer to each other: not left to gc


def _loop_state(agent: BaselineAgent, collector: Any, recorder: Any, table: Any) -> dict[str, Any]:
    """The run state's entries of the loop's parts: trial rows (taken and pending), the
    agent, the robots' worlds and the observation the next step acts on, the trials in
    progress, torch's generator."""
    collected = collector.state_dict()
    return {
        "rows": table.rows,
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
    return SharedTrials(episodes, state["rows"], state["pending"])


def _result(
    algorithm: str,
    priors: Priors,
    seed: int,
    map: str,
    envs: int,
    cfg: Any,
    run: _Run,
    stopped: bool,
) -> dict[str, Any]:
    """What :func:`train_baseline` returns."""
    wall, cpu = run.elapsed()
    rows, at20 = run.table.rows, run.at20
    return {
        "algorithm": algorithm,
        "variant": priors.label(),
        "priors": asdict(priors),
        "seed": seed,
        "map": map,
        "envs": envs,
        "settings": asdict(cfg),
        "rows": rows,
        "stopped": stopped,
        "at20": {
            **summarise(rows, 20),
            "wall_time_s": at20[0] if at20 else None,
            "frames": at20[1] if at20 else None,
        },
        "end": {
            **summarise(rows, run.table.total),
            "wall_time_s": round(wall, 1),
            "frames": run.loop.frames,
        },
        "cpu_time_s": round(cpu, 1),
    }


# ---------------------------------------------------------------------------------------------
# The command


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


def baseline_settings(
    algorithm: str, priors: Priors, seed: int, envs: int, cfg: Any
) -> dict[str, Any]:
    """What a run records as its settings (``config.yaml``; checked on ``--resume``)."""
    return {
        "baseline": algorithm,
        "priors": asdict(priors),
        "seed": seed,
        "envs": envs,
        algorithm: asdict(cfg),
    }
