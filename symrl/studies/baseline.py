"""The deep-RL baselines' common part (``symrl baseline {ppo,sac}``): env, loop, run folder.

A baseline is an *agent* (:mod:`symrl.studies.sac`, :mod:`symrl.studies.ppo`): a TorchRL actor
that writes ``control`` in [-1, 1] and an update that learns from batches of transitions.
Everything else is shared and is symrl's own:

    env    = TransformedEnv(BatchedWorldEnv(B robots), PriorObservation)   observation [+priors]
    td = env.reset()
    loop:
        agent.act(td); PriorAction(td)               control -> action (residual: reflex + c)
        td, next_td = env.step_and_maybe_reset(td)   TorchRL's stepping primitive
        recorder.step(td); agent.observe(td)         the trial table; the update
        ended trials -> RunWriter.trial (trials.csv, TensorBoard)
        td = next_td

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

import argparse
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch
import yaml
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModuleBase

from symrl.knowledge.reflex import ReflexConfig
from symrl.learner.config import RunConfig, config_to_dict, load_config
from symrl.studies.actor import make_actor
from symrl.studies.priors import PriorAction, PriorObservation, Priors

__all__ = [
    "Agent",
    "make_env",
    "make_actor",
    "run_config",
    "train_baseline",
    "summarise",
    "first_reliable",
    "BaselineController",
    "load_baseline",
    "load_run_state",
    "knowledge_of",
    "baseline_command",
    "CHECKPOINT_KIND",
]

CHECKPOINT_KIND = "baseline"
SNAPSHOT_FORMAT = 1
"""Format of the run state a baseline checkpoint holds (``symrl baseline ... --resume``)."""
RELIABLE_WINDOW, RELIABLE_LEVEL = 20, 0.8


class Agent(Protocol):
    """What the loop needs of an algorithm."""

    actor: Any
    """TorchRL actor: reads ``observation``, writes ``control`` (checkpointed)."""
    actor_spec: dict[str, Any]
    """``make_actor`` arguments that rebuild ``actor`` (cells, activation)."""

    def act(self, td: TensorDictBase) -> TensorDictBase:
        """Write ``control`` for every robot (exploring)."""
        ...

    def observe(self, td: TensorDictBase) -> None:
        """Learn from one batch [B] of transitions (root + ``next``)."""
        ...

    def state(self) -> dict[str, Any]:
        """Everything the agent has learnt and holds (networks, optimiser, data), as tensors
        and plain values: with it a run goes on between two steps (resume)."""
        ...

    def load_state(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state` (a fresh agent of the same settings)."""
        ...


# ---------------------------------------------------------------------------------------------
# Env and networks


def run_config(map: str = "hailu2001", seed: int = 100, episodes: int = 20) -> RunConfig:
    """The paper recipe's env, reflex and shield (the world and knowledge the paper's learner
    gets), with this run's map, seed and budget, except the reflex's output sets at their full
    size (``ReflexConfig.peaks`` default, +-pi/2). That is the better base for a residual
    learner: the shielded reflex alone scores 41.8 actions / -21.10 with them and 93.2 /
    -65.45 with `paper`'s halved sets, SAC residual at 20 trials 43.9 / -23.19 against 48.5 /
    -25.45 (seeds 100-104; RESULTS.md, "Modern baselines")."""
    peaks = list(ReflexConfig().peaks)
    return load_config(
        "paper_map",
        [
            f"env.map={map}",
            f"run.seed={seed}",
            f"run.trials={episodes}",
            f"run.image_every={max(episodes // 4, 1)}",
            f"reflex.peaks={peaks}",
        ],
    )


def robot_seeds(seed: int, envs: int) -> list[int]:
    """Robot k's world seed: ``seed`` for k = 0 (the robot of ``symrl train --seed seed``)."""
    return [seed] + [seed * 1000 + k for k in range(1, envs)]


def make_env(config: RunConfig, priors: Priors, seeds: Sequence[int], world: Any = None):
    """``BatchedWorldEnv`` (one robot per seed) with the :class:`PriorObservation` transform."""
    from torchrl.envs import TransformedEnv

    from symrl.train import make_env as make_world
    from symrl.world.worldmap import load_map

    world = world if world is not None else load_map(config.env.map)
    base = make_world(config, list(seeds), world=world)
    return TransformedEnv(base, PriorObservation(priors, config, world))


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
# Checkpoints and greedy trials


def save_baseline(
    path: Path,
    algorithm: str,
    agent: Agent,
    priors: Priors,
    config: RunConfig,
    world: Any,
    seed: int,
    n_obs: int,
    resume: dict[str, Any] | None = None,
) -> None:
    """The actor, how to rebuild it, the priors, config and map content: self-contained; with
    ``resume`` also the run state to go on from (:func:`load_run_state`). Written atomically: a
    crash leaves the previous file."""
    from symrl.about import provenance
    from symrl.runs import CHECKPOINT_FORMAT, _atomic_save, _map_content

    _atomic_save(
        {
            **({"resume": resume} if resume is not None else {}),
            "format": CHECKPOINT_FORMAT,
            "kind": CHECKPOINT_KIND,
            "algorithm": algorithm,
            "provenance": provenance(),
            "priors": asdict(priors),
            "actor_spec": {"n_obs": n_obs, **agent.actor_spec},
            "config": config_to_dict(config),
            "map": _map_content(world),
            "seed": int(seed),
            "actor": agent.actor.state_dict(),
        },
        path,
    )


def load_run_state(
    logdir: str | Path,
    settings: dict[str, Any],
    episodes: int,
    knowledge: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The run state in ``logdir/checkpoint.pt`` to go on to ``episodes`` trials, checked
    against this run's ``settings`` (algorithm, priors, seed, robots, hyper-parameters) and
    ``knowledge`` (the ``env``, ``reflex`` and ``shield`` sections it would use, checked against
    the run's ``config.yaml``: a recipe changed since the run started must not go on silently
    with another reflex). Every fault is one line naming the folder: no run there, no run
    state, another format, other settings or knowledge, a budget below what is done."""
    from symrl.runs import CheckpointError, read_checkpoint_file

    folder = Path(logdir)
    path = folder / "checkpoint.pt"
    if not path.is_file():
        raise CheckpointError(f"--resume {str(folder)!r}: no checkpoint.pt in it")
    data = read_checkpoint_file(path, f"--resume {str(folder)!r}")
    state = data.get("resume") if isinstance(data, dict) else None
    if not isinstance(data, dict) or data.get("kind") != CHECKPOINT_KIND:
        raise CheckpointError(f"--resume {str(folder)!r}: not a baseline run")
    if not isinstance(state, dict):
        raise CheckpointError(
            f"--resume {str(folder)!r}: the checkpoint holds the actor only, "
            "no run state to go on from"
        )
    if state.get("format") != SNAPSHOT_FORMAT:
        raise CheckpointError(
            f"--resume {str(folder)!r}: run state format {state.get('format')!r}, this symrl "
            f"resumes format {SNAPSHOT_FORMAT}"
        )
    saved, given = _flat(state.get("settings", {})), _flat(settings)
    if knowledge is not None:
        recorded = _config_yaml(folder)
        saved.update(_flat({k: recorded.get(k) for k in knowledge}))
        given.update(_flat(yaml.safe_load(yaml.safe_dump(knowledge))))  # as config.yaml has it
    for key in sorted(set(saved) | set(given)):
        if saved.get(key) != given.get(key):
            raise CheckpointError(
                f"--resume {str(folder)!r}: the run has {key} {saved.get(key)!r}, this command "
                f"{given.get(key)!r}"
            )
    done = len(state["rows"])
    if episodes < done:
        raise ValueError(
            f"--episodes {episodes}: the run in {str(folder)!r} has done {done} trials already"
        )
    return state


def _config_yaml(folder: Path) -> dict[str, Any]:
    """The run's ``config.yaml`` as written at its start (empty if missing or unreadable)."""
    try:
        doc = yaml.safe_load((folder / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return {}
    return doc if isinstance(doc, dict) else {}


def knowledge_of(config: RunConfig, priors: Priors | None = None) -> dict[str, Any]:
    """The world and knowledge sections of ``config``: ``env``, ``reflex`` and ``shield``;
    with ``priors`` only those a run with them uses (the reflex and the shield act only in a
    residual run)."""
    tree = config_to_dict(config)
    used = ("env", "reflex", "shield") if priors is None or priors.residual else ("env",)
    return {key: tree[key] for key in used}


def _flat(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested settings as ``{"ppo.hidden": 64, ...}`` (an error names the one that differs)."""
    out: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


class BaselineController(TensorDictModuleBase):
    """A trained baseline as a controller of B robots: actor, then :class:`PriorAction`.

    Has the two things :func:`symrl.evaluate.rollout` asks of a controller (``batch``,
    ``begin_trial``); greedy under TorchRL's DETERMINISTIC exploration type (the actor's mode).
    """

    def __init__(
        self,
        actor: Any,
        priors: Priors,
        config: RunConfig,
        world: Any,
        algorithm: str,
        batch: int = 1,
    ) -> None:
        super().__init__()
        self.actor, self.priors, self.config, self.world = actor, priors, config, world
        self.algorithm, self.batch = algorithm, batch
        self.to_action = PriorAction(priors, config)
        self.in_keys = ["observation", *self.to_action.in_keys[1:]]
        self.out_keys = ["control", "action", "shielded"]

    def begin_trial(self, rows: torch.Tensor) -> None:
        """Nothing to forget between trials (no per-trial state)."""

    @torch.no_grad()
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        self.actor(td)
        return self.to_action(td)

    def evaluate(
        self, starts: Sequence[Any] | None = None, seed: int = 0, world: Any = None
    ) -> list[dict[str, Any]]:
        """One greedy trial from each start (radians; None: the map's start), noise on."""
        from symrl.evaluate import rollout

        starts = list(starts) if starts else [None]
        world = world if world is not None else self.world
        if self.priors.regions and len(world.regions.names) != len(self.world.regions.names):
            raise ValueError(
                f"--map {world.name}: {len(world.regions.names)} regions, the controller was "
                f"trained with a one-hot of {len(self.world.regions.names)}"
            )
        env = make_env(self.config, self.priors, [seed + k for k in range(len(starts))], world)
        if any(s is not None for s in starts):
            home = (world.start.x, world.start.y, world.start.heading)
            env.base_env.set_starts(np.array([s if s is not None else home for s in starts]))
        self.batch = len(starts)
        try:
            return rollout(self, env)
        finally:
            env.close()


def load_baseline(path: str | Path) -> BaselineController | None:
    """The controller in a baseline checkpoint; None if the file is another kind (the paper
    learner's, read by :func:`symrl.runs.load_checkpoint`). Faults: one-line CheckpointError."""
    from symrl.learner.config import ConfigError, config_from_dict
    from symrl.runs import CheckpointError
    from symrl.world.worldmap import MapError, load_map

    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # noqa: BLE001 - load_checkpoint reports unreadable files
        return None
    if not isinstance(data, dict) or data.get("kind") != CHECKPOINT_KIND:
        return None
    try:
        config = config_from_dict(dict(data["config"]), recipe="paper_map")
        world = load_map(data["map"]) if data.get("map") else load_map(config.env.map)
        priors = Priors(**data["priors"])
        spec = dict(data["actor_spec"])
        actor = make_actor(int(spec["n_obs"]), spec["cells"], spec["activation"])
        actor.load_state_dict(data["actor"])
    except (ConfigError, MapError) as err:
        raise CheckpointError(f"checkpoint {str(path)!r}: {err}") from None
    except (KeyError, TypeError, RuntimeError) as err:
        detail = str(err).splitlines()[0][:160] if str(err) else type(err).__name__
        raise CheckpointError(
            f"checkpoint {str(path)!r}: not a usable baseline ({detail})"
        ) from None
    return BaselineController(actor, priors, config, world, str(data.get("algorithm")))


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
    from tqdm.auto import tqdm

    from symrl.runs import BASE_COLUMNS, RunWriter
    from symrl.train import TrialRecorder
    from symrl.world.worldmap import load_map

    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"--episodes {episodes!r}: must be an integer >= 1")
    if checkpoint_every < 1:
        raise ValueError(f"--checkpoint-every {checkpoint_every!r}: must be >= 1")
    priors = priors or Priors()
    agent_cls, cfg_cls = _algorithms()[algorithm]
    cfg = cfg_cls(**settings)
    envs = cfg.envs if envs is None else envs
    if isinstance(envs, bool) or not isinstance(envs, int) or envs < 1:
        raise ValueError(f"--envs {envs!r}: must be an integer >= 1")
    run_settings = _settings(algorithm, priors, seed, envs, cfg)
    config = run_config(map, seed, episodes)
    state = None
    if resume:
        if logdir is None:
            raise ValueError("resume: needs the run folder (logdir)")
        state = load_run_state(logdir, run_settings, episodes, knowledge_of(config, priors))
    torch.manual_seed(seed)
    t0, cpu0 = time.perf_counter(), time.process_time()
    world = load_map(config.env.map)
    env = make_env(config, priors, robot_seeds(seed, envs), world)
    n_obs = env.observation_spec["observation"].shape[-1]
    agent = agent_cls(cfg, n_obs, envs)
    to_action = PriorAction(priors, config)
    recorder = TrialRecorder(envs)
    rows: list[dict[str, Any]] = []
    pending: list[dict[str, Any]] = []  # trials that ended in the step the budget was reached
    frames, at20, wall0, cpu_before = 0, None, 0.0, 0.0
    writer = None
    if logdir is not None:
        settings_out = {**run_settings, "episodes": episodes, **knowledge_of(config)}
        writer = RunWriter(
            logdir,
            config,
            world,
            overwrite=overwrite,
            resume_rows=state["rows"] if state is not None else None,
            columns=list(BASE_COLUMNS),
            settings=settings_out,
        )
    if state is not None:
        agent.load_state(state["agent"])
        env.base_env.load_run_state(state["env"])
        recorder.load_state(state["recorder"])
        torch.set_rng_state(state["torch_rng"])
        rows, pending = list(state["rows"]), list(state["pending"])
        frames, wall0, cpu_before = int(state["frames"]), state["wall_s"], state["cpu_s"]
        at20 = tuple(state["at20"]) if state["at20"] is not None else None
    bar = tqdm(
        total=episodes,
        initial=len(rows),
        unit="trial",
        disable=not progress,
        desc=f"{algorithm} {priors.label()} seed {seed}",
        mininterval=5,
    )
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    def elapsed() -> tuple[float, float]:
        return (wall0 + time.perf_counter() - t0, cpu_before + time.process_time() - cpu0)

    def snapshot(td: TensorDictBase) -> None:
        if writer is None:
            return
        wall, cpu = elapsed()
        run_state = {
            "format": SNAPSHOT_FORMAT,
            "settings": run_settings,
            "rows": rows,
            "pending": pending,
            "agent": agent.state(),
            "env": env.base_env.run_state(),
            "recorder": recorder.state(),
            "torch_rng": torch.get_rng_state(),
            "td": td.to_dict(),
            "frames": frames,
            "wall_s": wall,
            "cpu_s": cpu,
            "at20": list(at20) if at20 is not None else None,
        }
        save_baseline(
            writer.dir / "checkpoint.pt",
            algorithm,
            agent,
            priors,
            config,
            world,
            seed,
            n_obs,
            resume=run_state,
        )

    def take(record: dict[str, Any]) -> None:
        rows.append(record)
        if writer is not None:
            writer.trial(record, last=len(rows) == episodes)
        nonlocal at20
        if len(rows) == min(20, episodes) and at20 is None:
            at20 = (round(elapsed()[0], 1), frames)
        bar.update()

    stopped = False
    try:
        with set_exploration_type(ExplorationType.RANDOM):
            td = env.reset() if state is None else TensorDict(state["td"], batch_size=[envs])
            while pending and len(rows) < episodes:
                take(pending.pop(0))
            while len(rows) < episodes:
                agent.act(td)
                to_action(td)
                td, next_td = env.step_and_maybe_reset(td)
                frames += envs
                done = recorder.step(td, torch.zeros(envs))
                agent.observe(td)
                before = len(rows)
                for b in np.flatnonzero(done):  # robots in index order
                    record = recorder.finish(int(b))
                    del record["mean_abs_td_error"]  # the paper learner's column
                    record.update(
                        trial=len(rows) + len(pending) + 1, reached_goal=bool(recorder.reached[b])
                    )
                    if len(rows) < episodes:
                        take(record)
                    else:
                        pending.append(record)
                if done.any():
                    rate = np.mean([r["reached_goal"] for r in rows[-20:]]) if rows else 0.0
                    bar.set_postfix(success20=f"{rate:.2f}")
                td = next_td
                if len(rows) // checkpoint_every > before // checkpoint_every:
                    snapshot(td)
                if stop is not None and stop() and len(rows) < episodes:
                    stopped = True
                    break
        snapshot(td)
        if writer is not None and not stopped:
            writer.finish(None, seed)
    finally:
        bar.close()
        if writer is not None:
            writer.close()
        env.close()
    wall, cpu = elapsed()
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
        "end": {**summarise(rows, episodes), "wall_time_s": round(wall, 1), "frames": frames},
        "cpu_time_s": round(cpu, 1),
    }


def _algorithms() -> dict[str, tuple[Any, Any]]:
    from symrl.studies.ppo import PPOAgent, PPOConfig
    from symrl.studies.sac import SACAgent, SACConfig

    return {"sac": (SACAgent, SACConfig), "ppo": (PPOAgent, PPOConfig)}


# ---------------------------------------------------------------------------------------------
# The command


MAX_SEEDS = 10_000
"""Most seeds (runs) one baseline command trains."""
MAX_ENVS = 1024
"""Most robots a baseline steps together (``--envs``): each holds its own world and buffers."""


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


def _settings(algorithm: str, priors: Priors, seed: int, envs: int, cfg: Any) -> dict[str, Any]:
    """What a run records as its settings (``config.yaml``; checked on ``--resume``)."""
    return {
        "baseline": algorithm,
        "priors": asdict(priors),
        "seed": seed,
        "envs": envs,
        algorithm: asdict(cfg),
    }


def _run_settings(args: argparse.Namespace, priors: Priors, seed: int) -> dict[str, Any]:
    """The settings of the run of ``args`` for ``seed``."""
    cfg = _algorithms()[args.algorithm][1]()
    return _settings(
        args.algorithm, priors, seed, cfg.envs if args.envs is None else args.envs, cfg
    )


def summary_markdown(results: list[dict[str, Any]]) -> str:
    """One row per seed and budget."""
    lines = [
        "| seed | trials | first success | first reliable (>= 80% of 20) | successes "
        "| last-5 actions | last-5 total reinf. | collisions | env steps | wall time (s) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in results:
        for part in ("at20", "end") if r["end"]["trials"] > 20 else ("end",):
            s = r[part]
            lines.append(
                f"| {r['seed']} | {s['trials']} | {s['first_success'] or 'never'} "
                f"| {s['first_reliable'] or 'never'} | {s['successes']} "
                f"| {s['last5_actions']:.1f} | {s['last5_total']:.2f} | {s['collisions']} "
                f"| {s['env_steps']} | {s['wall_time_s']} |"
            )
    return "\n".join(lines) + "\n"


def baseline_command(args: argparse.Namespace, signalled: list[int] | None = None) -> int:
    """``symrl baseline ALGO``: one run folder per seed (``OUT/seed-S``), a summary table.
    ``signalled`` (one worker): the signals received; the first stops the run between two steps
    with its state saved (``--resume`` goes on)."""

    seeds = parse_seeds(args.seeds)
    if args.episodes < 1:
        raise ValueError(f"--episodes {args.episodes}: must be >= 1")
    if args.envs is not None and not 1 <= args.envs <= MAX_ENVS:
        raise ValueError(f"--envs {args.envs}: must be within 1..{MAX_ENVS}")
    if args.correction is not None and not args.residual:
        raise ValueError(
            f"--correction {args.correction:g}: only with --residual (it bounds "
            "the residual's correction; without --residual it would be ignored)"
        )
    if args.workers < 1:
        raise ValueError(f"--workers {args.workers}: must be >= 1")
    if args.checkpoint_every < 1:
        raise ValueError(f"--checkpoint-every {args.checkpoint_every}: must be >= 1")
    if args.resume and args.overwrite:
        raise ValueError(
            "--resume goes on with the runs in --out, --overwrite replaces them: give one"
        )
    priors = Priors(
        residual=args.residual,
        regions=args.regions,
        correction=0.25 if args.correction is None else args.correction,
    )
    out = Path(args.out or f"results/baseline-{args.algorithm}-{priors.label()}")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r}: exists and is not a folder")
    runs = [out / f"seed-{s}" for s in seeds]
    resumed = [args.resume and (run / "checkpoint.pt").is_file() for run in runs]
    for run, goes_on in zip(runs, resumed, strict=True):
        if (run / "config.yaml").exists() and not (args.overwrite or goes_on):
            hint = (
                "it has no checkpoint.pt to go on from"
                if args.resume
                else "pass --overwrite to replace it, or --resume to go on with it"
            )
            raise FileExistsError(f"--out {str(out)!r}: {run.name} already holds a run ({hint})")
    for run, goes_on, seed in zip(runs, resumed, seeds, strict=True):
        if goes_on:  # every run's settings are checked before any of them trains
            load_run_state(
                run,
                _run_settings(args, priors, seed),
                args.episodes,
                knowledge_of(run_config(args.map, seed, args.episodes), priors),
            )
    from symrl.locks import holding

    with holding(out, "--out"):
        return _baseline_runs(args, signalled, seeds, priors, out, runs, resumed)


def _baseline_runs(
    args: argparse.Namespace,
    signalled: list[int] | None,
    seeds: list[int],
    priors: Priors,
    out: Path,
    runs: list[Path],
    resumed: list[bool],
) -> int:
    """The runs of ``symrl baseline`` once its inputs are checked (``out`` locked)."""
    from symrl.studies.runner import run_jobs

    t0 = time.perf_counter()
    stop = (lambda: bool(signalled)) if signalled is not None else None
    jobs = [
        {
            "algorithm": args.algorithm,
            "seed": s,
            "episodes": args.episodes,
            "priors": priors,
            "map": args.map,
            "envs": args.envs,
            "logdir": str(run),
            "overwrite": args.overwrite,
            "resume": goes_on,
            "checkpoint_every": args.checkpoint_every,
            **({"stop": stop} if stop else {}),
        }
        for s, run, goes_on in zip(seeds, runs, resumed, strict=True)
    ]
    if stop is None:
        results = run_jobs(
            train_baseline, jobs, workers=args.workers, desc=f"{args.algorithm} {priors.label()}"
        )
    else:  # one worker: here, seed after seed, until a signal stops the current run
        results = []
        for job in jobs:
            if signalled:
                break
            results.append(train_baseline(**job))
    if signalled:
        import signal

        where = "before its first run"
        if results:
            last = results[-1]
            where = (
                f"after {len(last['rows'])} of {args.episodes} trials of seed "
                f"{last['seed']} (its state is saved in {out}/seed-{last['seed']}/)"
            )
        print(
            f"symrl baseline: stopped by {signal.Signals(signalled[0]).name} {where}; go "
            "on with the same command and --resume",
            file=sys.stderr,
        )
        return 128 + int(signalled[0])
    wall = round(time.perf_counter() - t0, 1)
    summary = [{k: v for k, v in r.items() if k != "rows"} for r in results]
    before = out / "summary.json"  # runs of other seeds in the same folder are kept
    if before.is_file():
        kept = [
            r for r in json.loads(before.read_text()).get("runs", []) if r.get("seed") not in seeds
        ]
        summary = sorted(kept + summary, key=lambda r: r["seed"])
    (out / "summary.json").write_text(json.dumps({"runs": summary, "wall_time_s": wall}, indent=2))
    md = summary_markdown(results)
    (out / "summary.md").write_text(md)
    from symrl.figures import plot_baseline

    plot_baseline(
        results, out / "curves.png", f"{args.algorithm.upper()} ({priors.label()}), map {args.map}"
    )
    print(md)
    print(
        f"wrote {out}/ (seed-*/ run folders, summary.md, summary.json, curves.png); "
        f"wall time {wall} s"
    )
    return 0
