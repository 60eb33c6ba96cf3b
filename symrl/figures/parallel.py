"""Figures drawn in parallel: jobs shared out over forked helper processes (Linux), this
process taking its share."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence


def draw_in_parallel(jobs: Sequence[Callable[[], None]], workers: int | None = None) -> None:
    """Run ``jobs`` (each draws and saves its own figures) in up to ``workers`` processes (None:
    one per core), largest first as given; this process takes its share.

    Matplotlib draws in one thread, and a PNG of a few panels costs 0.1-0.3 s of layout, Agg
    rendering and encoding: a study's three figures are about 0.6 s, split over two cores about
    0.35 s. The helpers are forked (Linux; elsewhere the jobs run here, one after the other),
    so they share the data already in memory. A job a helper did not finish (an error, a
    killed helper) runs again here, where its error is raised with its traceback."""
    import multiprocessing
    import os
    import sys

    workers = min(len(jobs), os.cpu_count() or 1) if workers is None else min(workers, len(jobs))
    if workers <= 1 or not sys.platform.startswith("linux"):
        for job in jobs:
            job()
        return
    ctx = multiprocessing.get_context("fork")
    taken = ctx.Value("i", 0)  # the next job to take, shared
    finished = ctx.Array("b", len(jobs))  # 1 where a job is done

    def take_jobs() -> None:
        while True:
            with taken.get_lock():
                i = taken.value
                taken.value += 1
            if i >= len(jobs):
                return
            jobs[i]()
            finished[i] = 1

    def help_quietly() -> None:  # a stop (Ctrl-C, SIGTERM) is the command's to report
        with contextlib.suppress(KeyboardInterrupt):
            take_jobs()

    helpers = [ctx.Process(target=help_quietly, daemon=True) for _ in range(workers - 1)]
    for h in helpers:
        h.start()
    try:
        take_jobs()
    finally:
        for h in helpers:
            h.join()
    for i, job in enumerate(jobs):
        if not finished[i]:
            job()
