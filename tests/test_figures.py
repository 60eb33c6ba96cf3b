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


def _reaches_outside(fig) -> bool:
    """Whether anything drawn in ``fig`` (tick labels, axis labels, titles, legends) reaches
    outside the figure, i.e. is clipped in the PNG (what tight_layout would have measured)."""
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())  # inches
    width, height = fig.get_size_inches()
    return bool(
        drawn.x0 < -0.01 or drawn.y0 < -0.01 or drawn.x1 > width + 0.01 or drawn.y1 > height + 0.01
    )


@pytest.mark.parametrize("panels", [1, 2, 3, 4])
def test_the_study_figures_fixed_margins_keep_every_label_inside(tmp_path, monkeypatch, panels):
    """The study figures are laid out by fixed margins, not tight_layout: every tick label,
    axis label and title must still lie inside the figure, for the paper's map and a wide one."""
    import matplotlib.pyplot as plt
    import numpy as np

    from symrl import figures
    from symrl.world import load_map

    kept: list = []
    close = plt.close
    monkeypatch.setattr(figures.plt, "close", kept.append)
    path = [[0.0, 0.0], [1.0, -0.5], [3.5, -0.5], [4.0, -2.0]]
    for world in (load_map("hailu2001"), load_map("two_doors")):
        figures.plot_paths(
            world,
            [
                (f"panel {i}: final controller from 4 other starts", [path], [path])
                for i in range(panels)
            ],
            tmp_path / "p.png",
            columns=2,
        )
    curves = {
        k: np.random.default_rng(0).normal(size=(3, 20)) * 30
        for k in ("neurons", "steps", "total_reinforcement")
    }
    figures.plot_curves(curves, tmp_path / "c.png", title="paper: mean over 10 sets")
    assert len(kept) == 3
    for fig in kept:
        assert not _reaches_outside(fig)
        close(fig)


def test_paths_panels_fill_their_grid_and_name_their_paths(tmp_path, monkeypatch):
    """Three panels at two columns go in one row (no empty panel); a mapping of paths puts
    their names in the legend."""
    import matplotlib.image
    import matplotlib.pyplot as plt

    from symrl.figures import plot_paths
    from symrl.world.worldmap import load_map

    legends = []
    real_close = plt.close

    def spy(fig=None):
        if fig is not None and hasattr(fig, "axes"):
            legends.extend(
                t.get_text()
                for ax in fig.axes
                if ax.get_legend()
                for t in ax.get_legend().get_texts()
            )
        real_close(fig)

    monkeypatch.setattr(plt, "close", spy)
    path = [(0.0, 0.0), (1.0, 0.0), (2.0, -0.5)]
    panels = [
        ("a", {"trial 1": path, "trial 4": path[:2]}, []),
        ("b", [path], []),
        ("c", [path], []),
    ]
    plot_paths(load_map("hailu2001"), panels, tmp_path / "p.png", columns=2)
    height, width = matplotlib.image.imread(tmp_path / "p.png").shape[:2]
    assert width > 2.5 * height  # one row of three
    assert {"trial 1", "trial 4", "start"} <= set(legends)
