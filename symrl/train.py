"""Online training of B independent robots in one TorchRL loop (``symrl train``).

Readable top to bottom, as TorchRL's own recipes read:

    env = BatchedWorldEnv(B robots, robot b seeded seeds[b])       the world, batch [B]
    policy = MixtureOfExpertsPolicy(config, seeds)                  acts (gate, experts, reflex)
    env = env.append_transform(policy.perception_transform())      what the robot perceives
    collector = StepCollector(env, policy)                          one step of B robots a batch
    update = TeseoUpdate(policy)                                    learns (TESEO update)
    for batch in collector:
        update(batch)                                               per-transition update
        for robots whose trial ended: update.end_trial, record the trial

The collector (:class:`symrl.collector.StepCollector`, a TorchRL collector) steps the env with
``step_and_maybe_reset``, restarting the robots whose trial ended (partial resets); why it is
not TorchRL's ``Collector`` itself (which gives the same trials at two thirds of the speed at
B = 10) is measured in its module docstring. The perception transform marks each trial's first
state (``is_init``), where the policy forgets the last trial's decisions: the loop makes no
call into the policy. The update of a transition runs before the policy acts on its next
state: the paper's "adapt the previous winner before acting".

Robot b is the same run as ``symrl train RECIPE --seed seeds[b]`` alone: its world, its
exploration and its option choices draw from its own streams, and every batched operation
computes each row on its own. A robot that has done its trials keeps driving (it cannot be
taken out of the batch) but its controller was saved when it finished; the loop ends when the
last robot is done.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from symrl.assembly import make_env
from symrl.learner.config import RunConfig
from symrl.learner.experts import expert_names
from symrl.tensordicts import read

__all__ = [
    "TrainResult",
    "train",
    "train_batch",
    "make_env",
    "TrialRecorder",
    "run_snapshot",
    "check_memory",
    "restore_snapshot",
]


@dataclass
class TrainResult:
    """One robot's run: its trial records and final controller (a B = 1 policy)."""

    config: RunConfig
    seed: int
    trials: list[dict[str, Any]]
    policy: Any
    timings: dict[str, float] = field(default_factory=dict)
    world: Any = None
    """The world the robot learned in (the env's; the policy holds only what it was told)."""


# ---------------------------------------------------------------------------------------------
# Trial bookkeeping


_RECORDER_ARRAYS = ("steps", "total", "collisions", "shielded", "td_error", "_start", "_first")


class TrialRecorder:
    """Per-robot accumulators of the current trial, read from each batch of transitions."""

    def __init__(self, batch: int) -> None:
        self.batch = batch
        self.steps = np.zeros(batch, dtype=np.int64)
        self.total = np.zeros(batch)
        self.collisions = np.zeros(batch, dtype=np.int64)
        self.shielded = np.zeros(batch, dtype=np.int64)
        self.td_error = np.zeros(batch)
        self._poses: list[np.ndarray] = []  # (B, 2) true positions after each step
        self._winners: list[np.ndarray] = []  # (B,) expert/winner id acting at each step
        self._offset = 0  # global step of _poses[0]
        self._start = np.zeros(batch, dtype=np.int64)  # global step each trial started at
        self._first = np.zeros((batch, 2))  # the trial's start position

    def step(self, td, td_error: torch.Tensor) -> np.ndarray:
        """Record one transition of every robot; return the mask of robots whose trial ended."""
        nxt = read(td, "next")
        fresh = self.steps == 0
        if fresh.any():
            self._first[fresh] = read(td, "true_pose")[:, :2].numpy()[fresh]
        self.steps += 1
        # numpy on the tensors' memory: a numpy call costs a fraction of a torch op's dispatch
        self.total += read(nxt, "reward").numpy().reshape(-1)  # float32 widened exactly
        self.collisions += read(nxt, "collision").numpy().reshape(-1)
        self.shielded += read(td, "shielded").numpy()
        self.td_error += np.abs(td_error.numpy())
        self.reached = read(nxt, "reached_goal").reshape(-1)
        self._poses.append(read(nxt, "true_pose").numpy()[:, :2].copy())
        expert, winner = read(td, "expert", None), read(td, "winner", None)
        if expert is None:  # a controller without neurons (the baselines): no ghosts
            self._winners.append(np.zeros(self.batch, dtype=np.int64))
        else:
            self._winners.append(expert.numpy() * 1_000_003 + winner.numpy())
        return read(nxt, "done").numpy().reshape(-1).copy()

    def finish(self, b: int) -> dict[str, Any]:
        """Robot ``b``'s trial record (its path and ghosts included); resets its accumulators."""
        lo, hi = self._start[b] - self._offset, len(self._poses)
        # the steps' arrays joined in one call, then robot b's rows (not a Python loop over the
        # steps)
        path = np.concatenate(
            (self._first[b : b + 1], np.concatenate(self._poses[lo:hi])[b :: self.batch])
        )
        ids = np.concatenate(self._winners[lo:hi])[b :: self.batch]
        change = np.flatnonzero(np.concatenate(([True], ids[1:] != ids[:-1])))
        rounded = path.round(4)
        record: dict[str, Any] = {
            "steps": int(self.steps[b]),
            "total_reinforcement": float(self.total[b]),
            "collisions": int(self.collisions[b]),
            "shielded": int(self.shielded[b]),
            "mean_abs_td_error": float(self.td_error[b] / max(self.steps[b], 1)),
            # np.linalg.norm(axis=1)'s own formula, without its argument handling
            "path_length": float(np.sqrt(np.add.reduce(np.square(path[1:] - path[:-1]), 1)).sum()),
            "path": rounded.tolist(),
            "ghosts": rounded[change].tolist(),  # where the acting neuron changed
        }
        self.steps[b] = 0
        self.total[b] = self.collisions[b] = self.shielded[b] = self.td_error[b] = 0
        self._start[b] = self._offset + hi
        self._trim()
        return record

    def state(self) -> dict[str, Any]:
        """The accumulators of the trials in progress, as tensors (a run snapshot between two
        steps, the baselines' resume)."""
        arrays = {k: getattr(self, k) for k in _RECORDER_ARRAYS}
        reached = getattr(self, "reached", None)
        return {
            **{k: torch.from_numpy(v.copy()) for k, v in arrays.items()},
            "poses": torch.from_numpy(np.array(self._poses).reshape(-1, self.batch, 2)),
            "winners": torch.from_numpy(
                np.array(self._winners, dtype=np.int64).reshape(-1, self.batch)
            ),
            "offset": int(self._offset),
            "reached": None if reached is None else reached.clone(),
        }

    def load_state(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state`."""
        for k in _RECORDER_ARRAYS:
            setattr(self, k, state[k].numpy().copy())
        self._poses = list(state["poses"].numpy().copy())
        self._winners = list(state["winners"].numpy().copy())
        self._offset = int(state["offset"])
        if state["reached"] is not None:
            self.reached = state["reached"].clone()

    def _trim(self) -> None:
        drop = int(self._start.min()) - self._offset
        if drop > 512:  # forget steps no running trial needs
            del self._poses[:drop], self._winners[:drop]
            self._offset += drop


def _trial_extras(policy, rows: torch.Tensor, out: dict[str, torch.Tensor]) -> list[dict[str, Any]]:
    """The learner columns of the trial records of robots ``rows`` (``out``: what
    ``update.end_trial`` returned for them, with the temperature each trial explored with).
    Tensors are read once per call, not per robot."""
    # numpy on the buffers' memory: a small tensor's indexing costs a torch dispatch
    index = rows.numpy()
    counts = policy.experts.count.numpy()[index].tolist()
    replaced, improved = out["replaced"].tolist(), out["improved"].tolist()
    temperature = out["temperature"].tolist()
    choices = policy.options.choice.numpy()[index].tolist() if policy.options is not None else None
    extras = []
    for j in range(len(counts)):
        extra: dict[str, Any] = {"neurons": sum(counts[j])}
        extra.update(
            {f"neurons_{n}": c for n, c in zip(policy.expert_names, counts[j], strict=True)}
        )
        extra.update(temperature=temperature[j], replaced=replaced[j], improved=improved[j])
        crossings = policy.options.crossings if policy.options is not None else None
        if crossings is not None:
            extra.update(crossings.summary(int(index[j])))
        if choices is not None:
            labels = policy.options.labels
            for r, name in enumerate(policy.region_names):
                if choices[j][r] >= 0:
                    extra[f"option_{name}"] = labels[r][choices[j][r]]
        extras.append(extra)
    return extras


# ---------------------------------------------------------------------------------------------
# Training


def _available_memory() -> int:
    """Bytes of memory available now (Linux ``MemAvailable``; 8 GiB where unknown)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 8 << 30


def check_memory(config: RunConfig, batch: int, world: Any) -> int:
    """Bytes the expert storage of ``batch`` robots takes at ``experts.capacity``; a
    ValueError (one line, with the estimate) if that is over a quarter of the memory available
    (checkpoints and the end-of-trial updates copy it)."""
    xc = config.experts
    dim = config.env.robot.n_sensors + xc.goal_codes
    per_neuron = 4 * dim + 8 * 4 + 1  # centre (f32), action/utility/mean/taken (f64), used
    need = batch * len(expert_names(config, world)) * xc.capacity * per_neuron
    free = _available_memory()
    if need > free // 4:
        raise ValueError(
            f"experts.capacity={xc.capacity}: {batch} robot(s) would preallocate "
            f"{need / 2**30:.1f} GiB of expert storage, more than a quarter of the "
            f"{free / 2**30:.1f} GiB available; lower it (storage doubles when full, up to "
            "experts.max_neurons)"
        )
    return need


def train_batch(
    config: RunConfig,
    seeds: Sequence[int],
    progress: bool = True,
    on_trial: Any = None,
    world: Any = None,
    on_snapshot: Any = None,
    resume: dict[str, Any] | None = None,
    stop: Any = None,
    on_boundary: Any = None,
    resume_batch: dict[str, Any] | None = None,
) -> list[TrainResult]:
    """Train one robot per seed for ``config.run.trials`` trials, all in one batch.

    ``on_trial(b, record, policy)`` is called after every finished trial (logging, CSV rows).
    Returns one :class:`TrainResult` per seed, each with its final controller as a B = 1 policy.

    Resumable runs (one robot): ``on_snapshot(state)`` is called at every trial boundary with
    everything the run needs to go on (:func:`run_snapshot`); ``resume=state`` continues from
    such a state exactly as the uninterrupted run would have. ``stop()`` is asked after every
    step; when it answers True the loop ends there and the result holds the finished trials
    (``TrainResult.timings["stopped"]`` is 1).

    Resumable batches (any number of robots): ``on_boundary(snapshot)`` is called after every
    step at which a trial ended, with a function that returns the whole batch's state then
    (:func:`batch_snapshot`; the caller decides when it is worth building);
    ``resume_batch=state`` goes on from such a state as the uninterrupted batch would have.
    """
    from tqdm.auto import tqdm

    from symrl.assembly import assemble, build_policy

    seeds = [int(s) for s in seeds]
    batch, n_trials = len(seeds), config.run.trials
    if (resume is not None or on_snapshot is not None) and batch != 1:
        raise ValueError(f"train_batch: snapshots and resume need one robot, got {batch}")
    # env (perception transform appended), policy told config.knowledge, collector, update;
    # the config with the world's step budget
    run = assemble(config, seeds, world=world, check=check_memory)
    config, env, policy, update = run.config, run.env, run.policy, run.update
    collector = run.collector
    recorder = TrialRecorder(batch)
    trials: list[list[dict[str, Any]]] = [[] for _ in seeds]
    finals: list[dict[str, torch.Tensor] | None] = [None] * batch
    if resume_batch is not None:
        restore_batch_snapshot(resume_batch, collector, policy, update, recorder)
        trials = [[dict(r) for r in rows] for rows in resume_batch["trials"]]
        finals = [None if f is None else dict(f) for f in resume_batch["finals"]]
    if resume is not None:
        restore_snapshot(resume, collector, policy, update)
        trials[0] = [dict(r) for r in resume["trials"]]
        if len(trials[0]) >= n_trials:
            raise ValueError(
                f"--trials {n_trials}: the run has done {len(trials[0])} trials already; "
                "give a larger budget to go on"
            )
    label = config.recipe if batch == 1 else f"{config.recipe} x{batch}"
    bar = tqdm(
        total=n_trials * batch,
        desc=label,
        unit="trial",
        disable=not progress,
        initial=sum(len(t) for t in trials),
    )
    started, cpu_started = time.perf_counter(), time.process_time()
    frames, stopped = 0, False
    # nothing in the loop needs autograd: inference mode skips the version counters and the
    # autograd dispatch of every op (about a sixth of the learner's per-op cost, measured with
    # benchmarks/bench_train.py); tensors created here are inference tensors, which later code
    # only reads or clones
    with torch.inference_mode(), ExitStack() as contexts:
        contexts.callback(collector.shutdown)
        contexts.callback(bar.close)
        for td in collector:
            stats = update(td)
            frames += batch
            done = recorder.step(td, read(stats, "td_error"))
            if not done.any():
                if stop is not None and stop():
                    stopped = True
                    break
                continue
            # the rows as numpy and Python ints: indexing and reading small tensors element by
            # element costs a torch dispatch each
            ended = np.flatnonzero(done)
            rows, ended_list = torch.from_numpy(ended), ended.tolist()
            records = [recorder.finish(b) for b in ended_list]
            # float32 as torch.tensor of the floats makes it, for a fraction of its cost
            totals = torch.from_numpy(
                np.array([r["total_reinforcement"] for r in records], dtype=np.float32)
            )
            reached_np = recorder.reached.numpy()[ended]
            out = update.end_trial(rows, totals, torch.from_numpy(reached_np))
            extras = _trial_extras(policy, rows, out)
            for j, b in enumerate(ended_list):
                if finals[b] is not None:
                    continue  # this robot has done its trials: only driving on
                record = {"trial": len(trials[b]) + 1, **records[j]}
                record["reached_goal"] = bool(reached_np[j])
                record.update(extras[j])
                trials[b].append(record)
                bar.update(1)
                if batch == 1:
                    bar.set_postfix(
                        steps=record["steps"], total=f"{record['total_reinforcement']:.2f}"
                    )
                if on_trial is not None:
                    on_trial(b, record, policy)
                if len(trials[b]) == n_trials:
                    finals[b] = policy.robot_state(b)
            if on_snapshot is not None:
                on_snapshot(run_snapshot(collector, policy, update, trials[0]))
            if on_boundary is not None:
                on_boundary(
                    lambda: batch_snapshot(collector, policy, update, recorder, trials, finals)
                )
            if all(f is not None for f in finals):
                break
            if stop is not None and stop():
                stopped = True
                break
    elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    timings = {
        "seconds": elapsed,
        "cpu_seconds": cpu,
        "frames": frames,
        "robots": batch,
        "steps_per_second": frames / max(elapsed, 1e-9),
        "stopped": int(stopped),
    }
    results = []
    for b, seed in enumerate(seeds):
        single = build_policy(config, policy.knowledge, [seed], policy.subgoals)
        single.load_state_dict(finals[b] if finals[b] is not None else policy.robot_state(b))
        results.append(TrainResult(config, seed, trials[b], single, timings, env.world))
    return results


def train(
    config: RunConfig,
    progress: bool = True,
    on_trial: Any = None,
    on_snapshot: Any = None,
    resume: dict[str, Any] | None = None,
    stop: Any = None,
) -> TrainResult:
    """Train ``config.run.trials`` trials with ``config.run.seed`` (a batch of one robot);
    ``on_snapshot``, ``resume`` and ``stop`` as in :func:`train_batch`."""
    return train_batch(
        config,
        [config.run.seed],
        progress=progress,
        on_trial=on_trial,
        on_snapshot=on_snapshot,
        resume=resume,
        stop=stop,
    )[0]


# ---------------------------------------------------------------------------------------------
# Snapshots of a run at a trial boundary (resume)

SNAPSHOT_FORMAT = 2
"""2: the policy's learned counters under ``progress.`` and the option critic under
``options.critic.`` (format 1 held them at the top and under ``options.``)."""
_ROW_SKIP = ("path", "ghosts")


def run_snapshot(collector, policy, update, trials: list[dict[str, Any]]) -> dict[str, Any]:
    """Everything a one-robot run needs to go on from a trial boundary: the controller and
    the update's buffers, every random stream (the policy's exploration and option generators
    and its pre-drawn noise blocks, the robot's world generator), the robot's physics state and
    the observation of its next trial's start (the collector's state: its reset already drew
    from the world stream, the resumed run must not draw it again), and the trial rows so far
    (scalars; the last row keeps its path for the trajectory figure). Tensors and plain Python
    values only."""
    rows = [{k: v for k, v in r.items() if k not in _ROW_SKIP} for r in trials[:-1]]
    rows += [dict(r) for r in trials[-1:]]
    collected = collector.state_dict()
    return {
        "format": SNAPSHOT_FORMAT,
        "trials": rows,
        "policy": _trimmed(policy.state_dict(), int(policy.experts.count.max())),
        "loss": {k: v.clone() for k, v in update.state_dict().items()},
        **policy.random_state(),
        **collected["env_state_dict"],
        "td": collected["carrier"],
    }


BATCH_SNAPSHOT_FORMAT = 1


def _numpy_fields(obj: Any) -> dict[str, Any] | None:
    """The per-trial working state kept in ``obj``'s attributes (numpy arrays, and lists of
    arrays or None such as the route's paths) as tensors (copies); None for no ``obj``."""
    if obj is None:
        return None
    out: dict[str, Any] = {}
    for k, v in vars(obj).items():
        if isinstance(v, np.ndarray):
            out[k] = torch.from_numpy(v.copy())
        elif isinstance(v, list) and v and all(x is None or isinstance(x, np.ndarray) for x in v):
            out[k] = [None if x is None else torch.from_numpy(x.copy()) for x in v]
    return out


def _load_numpy_fields(obj: Any, state: dict[str, Any] | None) -> None:
    if obj is None or state is None:
        return
    for k, v in state.items():
        setattr(
            obj,
            k,
            [None if x is None else x.numpy().copy() for x in v]
            if isinstance(v, list)
            else v.numpy().copy(),
        )


def _working_parts(policy, update) -> dict[str, Any]:
    """The objects whose attributes hold a trial in progress beyond the state dicts: the trial
    gradient's record, the localiser's warm start, the options' step counts and route."""
    options = policy.options
    return {
        "loss_record": update.record,
        "tracker": policy.perception.tracker,
        "options": options,
        "route": getattr(options, "route", None),
    }


def batch_snapshot(
    collector,
    policy,
    update,
    recorder: TrialRecorder,
    trials: list[list[dict[str, Any]]],
    finals: list[dict[str, torch.Tensor] | None],
) -> dict[str, Any]:
    """Everything a batch of robots needs to go on from between two steps, robots in the middle
    of their trials included: the state of :func:`run_snapshot` for the whole batch, the trials
    in progress (the recorder's accumulators, the trial gradient's record, the localiser's warm
    start, the observation the next step acts on with its perception), the controllers of the
    robots that are done, and every robot's trial rows (the paths of its first trial and first
    trial to reach the goal and its last trial so far kept: a study draws them)."""
    rows_out = []
    for rows in trials:
        first_success = next((r["trial"] for r in rows if r["reached_goal"]), None)
        keep = {1, first_success, rows[-1]["trial"] if rows else None}
        rows_out.append(
            [
                dict(r)
                if r["trial"] in keep
                else {k: v for k, v in r.items() if k not in _ROW_SKIP}
                for r in rows
            ]
        )
    collected = collector.state_dict()
    return {
        "format": BATCH_SNAPSHOT_FORMAT,
        "trials": rows_out,
        "finals": [None if f is None else {k: v.clone() for k, v in f.items()} for f in finals],
        "policy": _trimmed(policy.state_dict(), int(policy.experts.count.max())),
        "loss": {k: v.clone() for k, v in update.state_dict().items()},
        "working": {k: _numpy_fields(v) for k, v in _working_parts(policy, update).items()},
        "recorder": recorder.state(),
        "random": policy.random_state(),
        "collector": {
            **collected,
            "frames": int(collected["frames"]),
            "iter": int(collected["iter"]),
        },
    }


def restore_batch_snapshot(
    state: dict[str, Any], collector, policy, update, recorder: TrialRecorder
) -> None:
    """Put a fresh batch (same config and seeds) into the state of :func:`batch_snapshot`."""
    if state.get("format") != BATCH_SNAPSHOT_FORMAT:
        raise ValueError(
            f"batch snapshot format {state.get('format')!r}, this symrl resumes "
            f"format {BATCH_SNAPSHOT_FORMAT}"
        )
    policy.load_state_dict(state["policy"])
    update.load_state_dict(state["loss"])
    for name, part in _working_parts(policy, update).items():
        _load_numpy_fields(part, state["working"].get(name))
    policy.load_random_state(state["random"])
    recorder.load_state(state["recorder"])
    collector.load_state_dict(state["collector"])


def _trimmed(state: dict[str, torch.Tensor], neurons: int) -> dict[str, torch.Tensor]:
    """Cloned state dict with the expert storage cut to the neurons in use (a large
    ``experts.capacity`` is mostly empty; the bank grows again from the saved size, with the
    same numbers)."""
    n = max(neurons, 1)
    return {
        k: (v[:, :, :n] if k.startswith("experts.") and v.dim() >= 3 else v).clone()
        for k, v in state.items()
    }


def restore_snapshot(state: dict[str, Any], collector, policy, update) -> None:
    """Put ``collector`` (its env), ``policy`` and ``update`` (fresh, same config and seed) into
    the state of :func:`run_snapshot`."""
    from tensordict import TensorDict

    policy.load_state_dict(state["policy"])
    update.load_state_dict(state["loss"])
    policy.load_random_state(state)
    td = TensorDict(state["td"], batch_size=collector.env.batch_size).clone()
    # the perception of the trial's first observation again: its localisation starts afresh
    # there, as in the uninterrupted run, and the next one is warm-started from it
    td = policy.perception_transform()(td)
    env_keys = collector.env.base_env.RUN_STATE_KEYS
    collector.load_state_dict(
        {
            "env_state_dict": {k: state[k] for k in env_keys},
            "carrier": td.to_dict(),
            "frames": 0,
            "iter": -1,
        }
    )
