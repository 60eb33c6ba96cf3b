"""The one study runner: N sets of a recipe as batches of robots, plus the statistics over sets.

Set k of a study is robot k of a batched training loop seeded ``seed + k`` (``symrl.train``), so
it is the same run as ``symrl train RECIPE --seed SEED+k`` alone, whatever the batch size or the
number of worker processes. ``workers`` > 1 splits the sets into that many batches, one per
process (None, the CLI's default: one per CPU core). Workers are forked where the platform
allows (Linux), so they start with torch, tensordict and torchrl already imported (a spawned
worker imports them again: 2-4 s each); with one core per worker a split study then trains
in about 1/``workers`` of the time, less the smaller batches' dearer steps.
"""

from __future__ import annotations

import functools
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symrl.learner.config import RunConfig, config_from_dict, config_to_dict, load_config

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

LAST = 5
"""Trials at the end of a set that its summary averages over."""
_SKIP = ("path", "ghosts")


@dataclass
class SetResult:
    """One set (one robot of a training batch): its trial rows, chosen paths and controller."""

    index: int
    seed: int
    rows: list[dict[str, Any]]
    paths: dict[int, list[list[float]]] = field(default_factory=dict)
    """Trial number -> true path, for the first, first successful and final trials."""
    ghosts: dict[int, list[list[float]]] = field(default_factory=dict)
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    """Greedy runs of the final controller from other start poses (with their paths)."""
    controller: dict[str, Any] = field(default_factory=dict)
    """The final controller's state dict (loads into a one-robot policy)."""
    timings: dict[str, float] = field(default_factory=dict)
    """Of the training batch this set ran in (shared by the sets of that batch)."""


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
            _save_set(kept_in, s, config_data, starts)
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
        done = {k: s for k in range(sets) if (s := _load_set(keep, k, data, starts)) is not None}
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
        _drop_batch_states(keep)
        return [done[k] for k in range(sets)]
    import queue
    from concurrent.futures import FIRST_COMPLETED, wait

    import torch
    from tqdm.auto import tqdm

    label = f"{config.recipe} x{len(todo)} ({len(jobs)} workers)"
    bar = tqdm(total=len(todo) * trials, desc=label, unit="trial", disable=not progress)
    trials_done = _fork_context().Queue() if progress else None
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
    _drop_batch_states(keep)
    return [done[k] for k in range(sets)]


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
        config_data, indices, seeds, starts, False, on_trial=_count_trial, kept_in=keep
    )
    for r in batch:
        r.controller = {k: v.numpy() for k, v in r.controller.items()}
    return batch


def _set_settings(data: dict[str, Any], index: int, starts: Sequence[Any]) -> dict[str, Any]:
    return {"config": data, "set": int(index), "starts": [[float(v) for v in s] for s in starts]}


def _save_set(folder: str | os.PathLike, s: SetResult, data: dict[str, Any], starts) -> None:
    import dataclasses
    from pathlib import Path

    from symrl.runs import _atomic_save

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    # the fields as they are (dataclasses.asdict deep-copies every row first: a third of the
    # save, for a record that is pickled and dropped)
    fields = {f.name: getattr(s, f.name) for f in dataclasses.fields(s)}
    record = {"settings": _set_settings(data, s.index, starts), "set": fields}
    _atomic_save(record, folder / f"set-{s.index:03d}.pt")


def _load_set(folder, index: int, data: dict[str, Any], starts) -> SetResult | None:
    """Set ``index`` as saved in ``folder`` if it was run with these settings, else None."""
    from pathlib import Path

    import torch

    path = Path(folder) / f"set-{index:03d}.pt"
    if not path.is_file():
        return None
    try:
        record = torch.load(path, map_location="cpu", weights_only=True)
        if record.get("settings") != _set_settings(data, index, starts):
            return None
        fields = dict(record["set"])
        fields["paths"] = {int(k): v for k, v in fields["paths"].items()}
        fields["ghosts"] = {int(k): v for k, v in fields["ghosts"].items()}
        return SetResult(**fields)
    except Exception:  # noqa: BLE001 - an unreadable or foreign file: run the set again
        return None


_TRIALS_DONE: Any = None
"""In a worker process: the queue its finished trials are counted on (None: not counted)."""


def _count_trial(*_: Any) -> None:
    if _TRIALS_DONE is not None:
        _TRIALS_DONE.put(1)


def _die_with_parent() -> None:
    """A worker ends when the command's process dies, even by ``kill -9`` (Linux: the parent
    death signal), instead of training on into a folder no process holds any more."""
    import ctypes
    import signal
    import sys

    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - no prctl: the worker may outlive it
        return
    if os.getppid() == 1:  # the parent died before the signal was set
        os._exit(1)


def _init_worker(trials_done: Any = None) -> None:
    import torch

    _die_with_parent()
    global _TRIALS_DONE
    _TRIALS_DONE = trials_done
    torch.set_num_threads(1)  # one core per worker; and a forked child must not reuse the
    # parent's OpenMP pool (torch's DataLoader workers do the same)


def _fork_context() -> Any:
    """Fork on Linux: a fork inherits the imported modules, where a spawned worker spends
    2-4 s importing torch, tensordict and torchrl again (more than a 10-set study trains).
    Spawn elsewhere (macOS and Windows do not fork safely)."""
    import multiprocessing
    import sys

    return multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")


def worker_pool(workers: int, trials_done: Any = None) -> Any:
    """A ``ProcessPoolExecutor`` of ``workers`` processes with one torch thread each (forked
    where the platform allows, see ``_fork_context``); ``trials_done``: a queue of that context
    on which the workers of :func:`run_sets` count their finished trials (the progress bar)."""
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(
        workers, mp_context=_fork_context(), initializer=_init_worker, initargs=(trials_done,)
    )


def run_jobs(
    fn: Any, jobs: Sequence[dict[str, Any]], workers: int | None = 1, desc: str = "jobs"
) -> list[Any]:
    """``fn(**job)`` for every job, in ``workers`` processes (1: here; see ``worker_pool``),
    in job order (for runs that are not batches of robots, e.g. the PPO baseline)."""
    from concurrent.futures import as_completed

    from tqdm.auto import tqdm

    workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    results: list[Any] = [None] * len(jobs)
    bar = tqdm(total=len(jobs), desc=desc, unit="run")
    if workers == 1:
        for i, job in enumerate(jobs):
            results[i] = fn(**job)
            bar.update()
    else:
        with worker_pool(workers) as pool:
            futures = {pool.submit(fn, **job): i for i, job in enumerate(jobs)}
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                bar.update()
    bar.close()
    return results


# --- statistics over sets ------------------------------------------------------------------


def last_trial_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The row of the last trial of every set (sets in increasing order)."""
    last: dict[int, dict[str, Any]] = {}
    for row in rows:
        s = int(row["set"])
        if s not in last or int(row["trial"]) > int(last[s]["trial"]):
            last[s] = row
    return [last[s] for s in sorted(last)]


def table1(
    rows: Sequence[dict[str, Any]],
    keys: Sequence[str] = (
        "neurons",
        "steps",
        "total_reinforcement",
        "collisions",
        "reached_goal",
        "path_length",
    ),
) -> dict[str, Any]:
    """Mean, sample variance (ddof 1), min and max over sets of each key at the last trial."""
    if not rows:
        raise ValueError("table1: no trial rows")
    last = last_trial_rows(rows)
    out: dict[str, Any] = {"sets": len(last), "trial": int(last[0]["trial"])}
    for key in keys:
        if key not in last[0]:
            continue
        v = np.array([float(r[key]) for r in last])
        out[key] = {
            "mean": float(v.mean()),
            "variance": float(v.var(ddof=1)) if len(v) > 1 else float("nan"),
            "min": float(v.min()),
            "max": float(v.max()),
        }
    return out


def curves(rows: Sequence[dict[str, Any]], key: str) -> np.ndarray:
    """(sets, trials) array of ``key`` (NaN where a set has fewer trials)."""
    sets = sorted({int(r["set"]) for r in rows})
    trials = sorted({int(r["trial"]) for r in rows})
    col = {t: j for j, t in enumerate(trials)}
    row = {s: i for i, s in enumerate(sets)}
    out = np.full((len(sets), len(trials)), np.nan)
    for r in rows:
        out[row[int(r["set"])], col[int(r["trial"])]] = float(r[key])
    return out


def mean_std(values: Sequence[float]) -> dict[str, Any]:
    """Mean and sample standard deviation, plus a 95 % bootstrap interval of the mean."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"mean": float("nan"), "std": float("nan"), "ci95": [float("nan")] * 2}
    rng = np.random.default_rng(0)  # fixed: the same rows give the same interval
    boot = rng.choice(v, size=(2000, v.size), replace=True).mean(axis=1)
    return {
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "ci95": [float(np.percentile(boot, 2.5)), float(np.percentile(boot, 97.5))],
    }


def summarise(rows: Sequence[dict[str, Any]], last: int = LAST) -> dict[str, Any]:
    """The summary of one recipe's sets: first success, success rate over the last ``last``
    trials, their mean actions and total reinforcement (per set, then mean, sd and a 95 %
    bootstrap interval over sets), neurons and collisions at the last trial, all collisions."""
    if not rows:
        raise ValueError("summarise: no trial rows")
    by_set: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_set.setdefault(int(r["set"]), []).append(r)
    never = 0
    firsts, success, steps, reinf, neurons, coll_last, coll_all = ([] for _ in range(7))
    opening: list[float] = []
    coll_tail = 0
    for s in sorted(by_set):
        trials = sorted(by_set[s], key=lambda r: int(r["trial"]))
        first = next((int(r["trial"]) for r in trials if bool(r["reached_goal"])), None)
        if first is None:
            never += 1
        else:
            firsts.append(first)
        tail = trials[-last:]
        success += [float(bool(r["reached_goal"])) for r in tail]
        steps.append(float(np.mean([float(r["steps"]) for r in tail])))
        reinf.append(float(np.mean([float(r["total_reinforcement"]) for r in tail])))
        neurons.append(float(trials[-1]["neurons"]))
        coll_last.append(float(trials[-1]["collisions"]))
        coll_all.append(sum(float(r["collisions"]) for r in trials))
        coll_tail += int(sum(float(r["collisions"]) for r in tail))
        opening.append(float(trials[0]["total_reinforcement"]))
    return {
        "sets": len(by_set),
        "trials": max(int(r["trial"]) for r in rows),
        "first_success": {**mean_std(firsts), "never": never},
        f"success_last{last}": float(np.mean(success)),
        f"steps_last{last}": mean_std(steps),
        f"total_reinforcement_last{last}": mean_std(reinf),
        "neurons_last": mean_std(neurons),
        "collisions_last": mean_std(coll_last),
        "collisions_all_trials": mean_std(coll_all),
        f"collisions_last{last}_sum": coll_tail,
        "total_reinforcement_first": mean_std(opening),
    }


def start_summary(results: Sequence[SetResult]) -> list[dict[str, Any]]:
    """Per other start pose: how many sets' final controllers reached the goal from it."""
    out = []
    for k in range(len(results[0].evaluations) if results else 0):
        evs = [r.evaluations[k] for r in results]
        out.append(
            {
                "start": evs[0]["start"],
                "reached": sum(e["reached_goal"] for e in evs),
                "sets": len(evs),
                "mean_steps_when_reached": (
                    float(np.mean([e["steps"] for e in evs if e["reached_goal"]]))
                    if any(e["reached_goal"] for e in evs)
                    else None
                ),
            }
        )
    return out


@functools.lru_cache(maxsize=8)
def _optimum(map_name: str) -> tuple[int, float]:
    from symrl.knowledge.planner import shortest_path
    from symrl.world import load_map

    plan = shortest_path(load_map(map_name))
    return plan.actions, round(plan.length, 3)


def optimum(map_name: str = "hailu2001") -> dict[str, Any]:
    """The shortest path of a map (``symrl plan``), for the tables (computed once per map)."""
    t0 = time.perf_counter()
    steps, length = _optimum(map_name)
    return {"steps": steps, "length_m": length, "seconds": round(time.perf_counter() - t0, 2)}
