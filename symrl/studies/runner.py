"""The one study runner: N sets of a recipe as batches of robots, trained and driven from
other starts.

Set k of a study is robot k of a batched training loop seeded ``seed + k`` (``symrl.train``), so
it is the same run as ``symrl train RECIPE --seed SEED+k`` alone, whatever the batch size or the
number of worker processes. ``workers`` > 1 splits the sets into that many batches, one per
process (None, the CLI's default: one per CPU core). Workers are forked where the platform
allows (Linux), so they start with torch, tensordict and torchrl already imported (a spawned
worker imports them again: 2-4 s each); with one core per worker a split study then trains
in about 1/``workers`` of the time, less the smaller batches' dearer steps.

The statistics over sets (:mod:`symrl.studies.stats`), a set's keeping on disk
(:mod:`symrl.studies.sets`) and the worker pool (:mod:`symrl.studies.workers`) have modules of
their own; their names used with the runner are importable from here too.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from symrl.learner.config import RunConfig, config_from_dict, config_to_dict, load_config
from symrl.studies.sets import SetResult, load_set, save_set
from symrl.studies.stats import (
    LAST,
    curves,
    last_trial_rows,
    mean_std,
    optimum,
    start_summary,
    summarise,
    table1,
)
from symrl.studies.workers import count_trial, fork_context, run_jobs, worker_pool

__all__ = [
    "SetResult",
    "resolve_config",
    "run_sets",
    "run_jobs",
    "worker_pool",
    "evaluate_states",
    "evaluation_batch",
    "last_trial_rows",
    "table1",
    "curves",
    "mean_std",
    "summarise",
    "start_summary",
    "optimum",
    "LAST",
]

_SKIP = ("path", "ghosts")


def resolve_config(recipe: str | RunConfig, overrides: Sequence[str] = ()) -> RunConfig:
    """A recipe name/path with overrides, or a ready config (overrides then applied to it)."""
    if isinstance(recipe, RunConfig):
        if not overrides:
            return recipe
        from symrl.learner.config import apply_overrides

        return apply_overrides(recipe, list(overrides))
    return load_config(recipe, list(overrides))


def _xy(path: Any) -> list[list[float]]:
    return np.asarray(path, dtype=float).reshape(-1, 2).round(4).tolist()


def evaluation_batch(
    config: RunConfig,
    world: Any,
    states: Sequence[dict[str, Any]],
    starts: Sequence[tuple[float, float, float]],
    seeds: Sequence[int],
    env_world: Any = None,
) -> tuple[Any, Any]:
    """The policy of controllers ``states`` and the env their robots drive in, from ``starts``.

    The agent is told ``world``, the map it learned in, at its rung (``config.knowledge``: at
    ``map`` its sub-goal table, planner and localiser are built from it); the env holds
    ``env_world`` (default ``world``), e.g. the same map with a new obstacle the agent is not
    told of."""
    from symrl.assembly import assemble_greedy

    place = world if env_world is None else env_world
    poses = np.asarray(starts, dtype=np.float64)
    return assemble_greedy(config, world, list(states), list(seeds), place, poses)


def evaluate_states(
    config: RunConfig,
    world: Any,
    states: Sequence[dict[str, Any]],
    starts: Sequence[tuple[float, float, float]],
    seeds: Sequence[int],
    env_world: Any = None,
    progress: str | None = None,
) -> list[dict[str, Any]]:
    """Greedy trials of controller ``states[i]`` from ``starts[i]`` with noise seed ``seeds[i]``,
    all in one batch; one compact record (with its path) per run. The agent knows ``world``,
    the robots drive in ``env_world`` (default ``world``): :func:`evaluation_batch`.
    ``progress``: the label of a bar counting their steps."""
    from symrl.evaluate import rollout

    if not states:
        return []
    policy, env = evaluation_batch(config, world, states, starts, seeds, env_world)
    try:
        records = rollout(policy, env, progress)
    finally:
        env.close()
    return [
        {
            "start": [float(v) for v in start],
            "reached_goal": bool(r["reached_goal"]),
            "steps": int(r["steps"]),
            "collisions": int(r["collisions"]),
            "total_reinforcement": float(r["total_reinforcement"]),
            "path": _xy(r["path"]),
        }
        for start, r in zip(starts, records, strict=True)
    ]


def _run_batch(
    config_data: dict[str, Any],
    indices: Sequence[int],
    seeds: Sequence[int],
    starts: Sequence[tuple[float, float, float]],
    progress: bool,
    on_trial: Any = None,
    kept_in: Any = None,
) -> list[SetResult]:
    """Train one robot per seed in one batch, then drive each final controller from ``starts``
    (runs in a worker process, or in this one); ``on_trial`` as for ``train_batch``. ``kept_in``:
    the study's folder of kept sets, where the batch's state is saved as it trains
    (:mod:`symrl.studies.checkpointing`) and from where a stopped batch goes on."""
    import torch

    from symrl.studies.checkpointing import BatchKeeper
    from symrl.train import train_batch

    torch.set_num_threads(1)
    config = config_from_dict(config_data)
    keeper = BatchKeeper(kept_in, config_data, indices, starts) if kept_in is not None else None
    results = train_batch(
        config,
        seeds,
        progress=progress,
        on_trial=on_trial,
        on_boundary=keeper.on_boundary if keeper is not None else None,
        resume_batch=keeper.saved() if keeper is not None else None,
    )
    out = []
    for index, res in zip(indices, results, strict=True):
        rows, paths, ghosts = [], {}, {}
        first_success = next((t["trial"] for t in res.trials if t["reached_goal"]), None)
        keep = {res.trials[0]["trial"], res.trials[-1]["trial"], first_success}
        for t in res.trials:
            rows.append(
                {"set": index, "seed": res.seed, **{k: v for k, v in t.items() if k not in _SKIP}}
            )
            if t["trial"] in keep:
                paths[int(t["trial"])] = _xy(t["path"])
                ghosts[int(t["trial"])] = _xy(t["ghosts"])
        out.append(
            SetResult(
                index,
                res.seed,
                rows,
                paths,
                ghosts,
                controller=res.policy.state_dict(),
                timings=res.timings,
            )
        )
    if starts:
        world = results[0].world
        pairs = [(s, k) for s in out for k in range(len(starts))]
        evs = evaluate_states(
            config,
            world,
            [s.controller for s, _ in pairs],
            [starts[k] for _, k in pairs],
            [s.seed + 1000 * (k + 1) for s, k in pairs],
            progress=f"{config.recipe}: {len(pairs)} greedy trials from other starts"
            if progress
            else None,
        )
        for (s, _), ev in zip(pairs, evs, strict=True):
            s.evaluations.append(ev)
    if keeper is not None:  # each set kept as set-K.pt, then the batch's state is not needed
        for s in out:
            save_set(kept_in, s, config_data, starts)
        keeper.done()
    return out


def run_sets(
    recipe: str | RunConfig,
    sets: int,
    trials: int,
    seed: int = 100,
    overrides: Sequence[str] = (),
    starts: Sequence[tuple[float, float, float]] = (),
    workers: int | None = 1,
    progress: bool = True,
    keep: str | os.PathLike | None = None,
    while_waiting: Callable[[], Any] | None = None,
) -> list[SetResult]:
    """Train ``sets`` sets (set k: ``seed + k``) of ``trials`` trials and drive each final
    controller from ``starts``; sets in order.

    ``while_waiting``: work of the caller's own (e.g. the map's optimum for the tables), done
    here once, as soon as one worker is done while another still runs (a core is free then),
    or after the last batch.

    ``keep``: a folder where each finished set is saved (``set-K.pt``, with the settings it was
    run with); a set found there with the same settings is loaded, not run again (set k is the
    same run whatever the batch it runs in, so a study re-run into the same folder after an
    interruption gives the same sets)."""
    if sets < 1 or trials < 1:
        raise ValueError(f"need at least 1 set and 1 trial, got sets={sets}, trials={trials}")
    workers = (os.cpu_count() or 1) if workers is None else workers  # None: one per core
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    config = resolve_config(recipe, [*overrides, f"run.trials={trials}", f"run.seed={seed}"])
    data = config_to_dict(config)
    done: dict[int, SetResult] = {}
    if keep is not None:
        done = {k: s for k in range(sets) if (s := load_set(keep, k, data, starts)) is not None}
    todo = np.array([k for k in range(sets) if k not in done], dtype=np.int64)
    waiting = [while_waiting] if while_waiting is not None else []
    if len(todo) == 0:
        for fn in waiting:
            fn()
        _drop_batch_states(keep)
        return [done[k] for k in range(sets)]

    def finished(batch: list[SetResult]) -> list[SetResult]:
        for s in batch:  # with ``keep``, saved by the batch itself (``_run_batch``)
            done[s.index] = s
        return batch

    workers = min(workers, len(todo), os.cpu_count() or 1)
    chunks = [[int(k) for k in c] for c in np.array_split(todo, workers) if len(c)]
    jobs = [(data, c, [seed + k for k in c], list(starts), keep) for c in chunks]
    if len(jobs) == 1:
        finished(_run_batch(*jobs[0][:4], progress=progress, kept_in=keep))
        for fn in waiting:
            _while_saying("the table's yardstick (the map's optimum)", fn, progress)
    else:
        label = f"{config.recipe} x{len(todo)} ({len(jobs)} workers)"
        _run_in_workers(jobs, label, len(todo) * trials, progress, waiting, finished)
    _drop_batch_states(keep)
    return [done[k] for k in range(sets)]


def _run_in_workers(
    jobs: list[tuple[Any, ...]],
    label: str,
    total: int,
    progress: bool,
    waiting: list[Callable[[], Any]],
    finished: Callable[[list[SetResult]], Any],
) -> None:
    """The batches ``jobs`` of :func:`run_sets`, one per worker process: each finished batch
    handed to ``finished`` as soon as it is done, the caller's ``waiting`` work done once a
    worker is free, and a bar of ``total`` trials counted by the workers as they finish."""
    import queue
    from concurrent.futures import FIRST_COMPLETED, wait

    import torch
    from tqdm.auto import tqdm

    bar = tqdm(total=total, desc=label, unit="trial", disable=not progress)
    trials_done = fork_context().Queue() if progress else None
    try:
        with worker_pool(len(jobs), trials_done) as pool:
            pending = {pool.submit(_run_batch_in_worker, *job) for job in jobs}
            while pending:
                ended, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
                for fut in ended:  # each batch saved as soon as it is done
                    batch = fut.result()
                    for r in batch:
                        r.controller = {k: torch.from_numpy(v) for k, v in r.controller.items()}
                    finished(batch)
                if ended and waiting:
                    _while_saying(
                        "the table's yardstick (the map's optimum)",
                        waiting.pop(),
                        progress and bool(pending),
                    )
                while trials_done is not None:
                    try:
                        bar.update(trials_done.get_nowait())
                    except queue.Empty:
                        break
        while trials_done is not None and bar.n < bar.total:  # counts sent before the last
            try:  # batch's result, still in the queue's pipe
                bar.update(trials_done.get(timeout=1.0))
            except queue.Empty:
                break
    finally:
        bar.close()
        if trials_done is not None:
            trials_done.close()


def _while_saying(what: str, fn: Callable[[], Any], say: bool) -> None:
    """``fn()``, said on stderr first when ``say`` (a long step no bar counts: on a big world
    the optimum takes a while)."""
    if not say:
        fn()
        return
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    tqdm.write(f"computing {what} ...", file=sys.stderr)
    fn()
    tqdm.write(f"computed {what} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)


def _drop_batch_states(keep: Any) -> None:
    """Every set is kept: no batch state is needed any more (one of another split into workers,
    left by a stopped run resumed with another --workers, included)."""
    if keep is not None:
        from symrl.studies.checkpointing import batch_files

        for path in batch_files(keep):
            path.unlink(missing_ok=True)


def _run_batch_in_worker(
    config_data: dict[str, Any],
    indices: Sequence[int],
    seeds: Sequence[int],
    starts: Sequence[tuple[float, float, float]],
    keep: Any = None,
) -> list[SetResult]:
    """:func:`_run_batch` in a worker process, its controllers as numpy arrays: a tensor sent
    between processes travels as a shared-memory file whose descriptor the receiver keeps open
    while the tensor lives, and an ablation of 40 sets x 20 variants holds ~20,000 of them
    (beyond the usual limit on open files). Each finished trial is counted on the pool's
    progress queue, if it has one."""
    batch = _run_batch(
        config_data, indices, seeds, starts, False, on_trial=count_trial, kept_in=keep
    )
    for r in batch:
        r.controller = {k: v.numpy() for k, v in r.controller.items()}
    return batch
