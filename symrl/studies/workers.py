"""The study's worker processes: a pool of forked workers with one torch thread each, that end
with the command's process, count their finished trials on a queue, and run jobs in order."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

_TRIALS_DONE: Any = None
"""In a worker process: the queue its finished trials are counted on (None: not counted)."""


def count_trial(*_: Any) -> None:
    """Count one finished trial on the pool's queue (a worker's ``on_trial``), if it has one."""
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


def fork_context() -> Any:
    """Fork on Linux: a fork inherits the imported modules, where a spawned worker spends
    2-4 s importing torch, tensordict and torchrl again (more than a 10-set study trains).
    Spawn elsewhere (macOS and Windows do not fork safely)."""
    import multiprocessing
    import sys

    return multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")


def worker_pool(workers: int, trials_done: Any = None) -> Any:
    """A ``ProcessPoolExecutor`` of ``workers`` processes with one torch thread each (forked
    where the platform allows, see ``fork_context``); ``trials_done``: a queue of that context
    on which the workers of :func:`run_sets` count their finished trials (the progress bar)."""
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(
        workers, mp_context=fork_context(), initializer=_init_worker, initargs=(trials_done,)
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
