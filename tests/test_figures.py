"""Drawing jobs shared out between processes: each runs once, and an error is raised here."""

import os
import sys

import pytest

from symrl.figures import draw_in_parallel


def _job(folder, i):
    def job():
        (folder / f"{i}.pid").write_text(str(os.getpid()))

    return job


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="helpers are forked on Linux")
def test_every_job_runs_once_and_two_run_at_once(tmp_path):
    import multiprocessing

    both = multiprocessing.get_context("fork").Barrier(2, timeout=30)  # passed only by 2 at once

    def meet(i):
        def job():
            both.wait()
            _job(tmp_path, i)()

        return job

    draw_in_parallel([meet(0), meet(1), *[_job(tmp_path, i) for i in range(2, 6)]], workers=2)
    pids = {(tmp_path / f"{i}.pid").read_text() for i in range(6)}
    assert len(list(tmp_path.glob("*.pid"))) == 6
    assert len(pids) == 2 and str(os.getpid()) in pids


def test_one_worker_runs_the_jobs_here_in_order(tmp_path):
    order = []
    draw_in_parallel([lambda i=i: order.append(i) for i in range(3)], workers=1)
    assert order == [0, 1, 2]


def test_a_failing_job_raises_here_with_its_error(tmp_path):
    def broken():
        raise ValueError("no such panel")

    jobs = [_job(tmp_path, 0), broken, _job(tmp_path, 2), _job(tmp_path, 3)]
    with pytest.raises(ValueError, match="no such panel"):
        draw_in_parallel(jobs, workers=2)
