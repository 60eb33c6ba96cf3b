"""Online training of B independent robots in one TorchRL loop (``symrl train``).

Readable top to bottom, as TorchRL's own recipes read:

    run = assemble(config, seeds)      the world cut to the recipe's knowledge (symrl.assembly);
                                       env of B robots + perception transform, policy,
                                       collector (one step of B robots a batch), update
    TrainingLoop(collector, TeseoAgent(policy, update), RobotTrials(B, trials), recorder).run()
        for batch in collector: update(batch); robots whose trial ended: update.end_trial,
        record the trial

The loop is :class:`symrl.loop.TrainingLoop`, the one every learner trains in; the paper's
learner is its agent :class:`symrl.teseo.TeseoAgent`. The collector
(:class:`symrl.collector.StepCollector`, a TorchRL collector) steps the env with
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
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from symrl.assembly import make_env
from symrl.learner.config import RunConfig
from symrl.learner.experts import expert_names
from symrl.loop import RobotTrials, TrainingLoop
from symrl.recorder import TrialRecorder
from symrl.teseo import TeseoAgent

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
    from symrl.assembly import assemble

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
    trials, finals = _resumed(resume_batch, resume, collector, policy, update, recorder, n_trials)
    agent = TeseoAgent(policy, update)
    hooks = {"on_trial": on_trial, "on_snapshot": on_snapshot, "on_boundary": on_boundary}
    return _train(
        config, seeds, env, collector, agent, recorder, trials, finals, progress, stop, hooks
    )


def _train(
    config: RunConfig,
    seeds: list[int],
    env: Any,
    collector: Any,
    agent: TeseoAgent,
    recorder: TrialRecorder,
    trials: list[list[dict[str, Any]]],
    finals: list[dict[str, torch.Tensor] | None],
    progress: bool,
    stop: Any,
    hooks: dict[str, Any],
) -> list[TrainResult]:
    """:func:`train_batch`'s loop once its parts are built (and resumed): the robots' own
    tables through :class:`symrl.loop.TrainingLoop`, the callbacks (``hooks``: ``on_trial``,
    ``on_snapshot``, ``on_boundary`` as :func:`train_batch` has them), the results."""
    policy, update = agent.policy, agent.update
    on_trial, on_snapshot, on_boundary = (
        hooks[k] for k in ("on_trial", "on_snapshot", "on_boundary")
    )
    batch, n_trials = len(seeds), config.run.trials
    table = RobotTrials(batch, n_trials, trials, closed=[f is not None for f in finals])

    def trial_ended(b: int, record: dict[str, Any]) -> None:
        if on_trial is not None:
            on_trial(b, record, policy)
        if len(trials[b]) == n_trials:
            finals[b] = policy.robot_state(b)

    def boundary(added: list[tuple[int, dict[str, Any]]]) -> None:
        if on_snapshot is not None:
            on_snapshot(run_snapshot(collector, policy, update, trials[0]))
        if on_boundary is not None:
            on_boundary(lambda: batch_snapshot(collector, policy, update, recorder, trials, finals))

    label = config.recipe if batch == 1 else f"{config.recipe} x{batch}"
    loop = TrainingLoop(
        collector,
        agent,
        table,
        recorder,
        on_trial=trial_ended,
        on_boundary=boundary,
        stop=stop,
        progress=progress,
        bar={"desc": label},
    )
    started, cpu_started = time.perf_counter(), time.process_time()
    # nothing in the loop needs autograd: inference mode skips the version counters and the
    # autograd dispatch of every op (about a sixth of the learner's per-op cost, measured with
    # benchmarks/bench_train.py); tensors created here are inference tensors, which later code
    # only reads or clones
    with torch.inference_mode():
        stopped = loop.run()
    elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    timings = {
        "seconds": elapsed,
        "cpu_seconds": cpu,
        "frames": loop.frames,
        "robots": batch,
        "steps_per_second": loop.frames / max(elapsed, 1e-9),
        "stopped": int(stopped),
    }
    robots = [_robot_policy(config, policy, b, s, finals[b]) for b, s in enumerate(seeds)]
    world = env.world
    return [
        TrainResult(config, s, trials[b], robots[b], timings, world) for b, s in enumerate(seeds)
    ]


def _robot_policy(
    config: RunConfig, policy: Any, b: int, seed: int, final: dict[str, torch.Tensor] | None
) -> Any:
    """Robot ``b``'s controller as a B = 1 policy: ``final`` (its state when it finished its
    trials) or its state now."""
    from symrl.assembly import build_policy

    single = build_policy(config, policy.knowledge, [seed], policy.subgoals)
    single.load_state_dict(final if final is not None else policy.robot_state(b))
    return single


def _resumed(
    resume_batch: dict[str, Any] | None,
    resume: dict[str, Any] | None,
    collector: Any,
    policy: Any,
    update: Any,
    recorder: TrialRecorder,
    n_trials: int,
) -> tuple[list[list[dict[str, Any]]], list[dict[str, torch.Tensor] | None]]:
    """The trial rows and finished robots' controllers of a fresh batch (none) or of a resumed
    one (``resume_batch``: :func:`batch_snapshot`; ``resume``: :func:`run_snapshot`, which
    must have fewer than ``n_trials`` trials), whose parts are put into the saved state."""
    batch = recorder.batch
    trials: list[list[dict[str, Any]]] = [[] for _ in range(batch)]
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
    return trials, finals


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
    """The per-trial working state kept in ``obj``'s attributes (numpy arrays, lists of arrays
    or None such as the route's paths, and dicts of arrays such as the remembered way's trial
    flags) as tensors (copies); None for no ``obj``."""
    if obj is None:
        return None
    out: dict[str, Any] = {}
    for k, v in vars(obj).items():
        if isinstance(v, np.ndarray):
            out[k] = torch.from_numpy(v.copy())
        elif isinstance(v, list) and v and all(x is None or isinstance(x, np.ndarray) for x in v):
            out[k] = [None if x is None else torch.from_numpy(x.copy()) for x in v]
        elif isinstance(v, dict) and v and all(isinstance(x, np.ndarray) for x in v.values()):
            out[k] = {name: torch.from_numpy(x.copy()) for name, x in v.items()}
    return out


def _load_numpy_fields(obj: Any, state: dict[str, Any] | None) -> None:
    if obj is None or state is None:
        return
    for k, v in state.items():
        if isinstance(v, dict):
            setattr(obj, k, {name: x.numpy().copy() for name, x in v.items()})
        elif isinstance(v, list):
            setattr(obj, k, [None if x is None else x.numpy().copy() for x in v])
        else:
            setattr(obj, k, v.numpy().copy())


def _working_parts(policy, update) -> dict[str, Any]:
    """The objects whose attributes hold a trial in progress beyond the state dicts: the trial
    gradient's record, the localiser's warm start, the options' step counts and route, the
    goal scans' trial flags, the wall follow's trail, the crossing map's last crossing, the
    remembered way's trial flags."""
    options = policy.options
    return {
        "loss_record": update.record,
        "tracker": policy.perception.tracker,
        "options": options,
        "route": getattr(options, "route", None),
        "goal_scans": getattr(options, "goal_scans", None),
        "wall_follow": getattr(options, "wall_follow", None),
        "crossings": getattr(options, "crossings", None),
        "remembered_way": getattr(options, "remembered_way", None),
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
