"""Every figure symrl writes: trial paths, the reflex's drive, the optimum, learning curves,
recipe comparisons, baselines.

The map itself is drawn by ``symrl.world.render`` (the world's own drawing primitives on an
Axes); these functions compose figures on top of it. Every ``plot_*`` writes one PNG and closes
its figure, so long studies do not accumulate open figures. Trial axes have integer ticks; paths
start with a marker; curves that coincide stay visible (each recipe its own marker, line style
and a small horizontal offset). Figures laid out by ``tight_layout`` are saved without
``bbox_inches="tight"``, which would draw the whole figure once more (about a sixth of a
study's drawing time) for the same margins. The study's figures (:func:`plot_paths`,
:func:`plot_curves`) have fixed margins in inches (:func:`_fixed_margins`) instead: their
panels are always the same kind, and ``tight_layout`` measures every tick label by laying the
figure out once more, about a third of their drawing time (measured on a study's three
figures: 0.22 / 0.13 / 0.14 s -> 0.15 / 0.09 / 0.09 s).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

if TYPE_CHECKING:
    from symrl.knowledge.planner import Plan
    from symrl.world import WorldMap

__all__ = [
    "draw_map",
    "trajectory_figure",
    "drive_figure",
    "plot_plan",
    "plot_paths",
    "plot_curves",
    "plot_comparison",
    "plot_map_comparison",
    "plot_baseline",
    "plot_learning_curves",
    "plot_reward_optimum",
    "plot_ladder_worlds",
    "draw_in_parallel",
    "crossings_figure",
    "plot_crossings",
]

_MARKERS = "osD^vP*Xh<>"
_STYLES = ("-", "--", "-.", ":")


def draw_map(ax: plt.Axes, world: WorldMap) -> None:
    """The world (walls, regions, goal), drawn by the world's own render module."""
    from symrl.world.render import draw_world

    draw_world(ax, world)


def _draw_xy(ax: plt.Axes, xy: Any, color: str, label: str | None = None) -> None:
    from symrl.world.render import draw_path

    draw_path(ax, xy, color=color, label=label)


def _start(ax: plt.Axes, xy: Any, label: str | None = "start") -> None:
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(xy):
        ax.plot(xy[0, 0], xy[0, 1], "o", ms=6, mfc="white", mec="black", zorder=5, label=label)


def _fixed_margins(
    fig: Any,
    rows: int,
    cols: int,
    left: float,
    bottom: float,
    top: float,
    gap_x: float,
    gap_y: float = 0.0,
    right: float = 0.15,
) -> None:
    """Lay out a grid of panels with margins and gaps in inches (room for the tick labels, the
    axis labels and the titles of panels of one kind)."""
    width, height = fig.get_size_inches()
    panel_w = (width - left - right - (cols - 1) * gap_x) / cols
    panel_h = (height - bottom - top - (rows - 1) * gap_y) / rows
    fig.subplots_adjust(
        left=left / width,
        right=1.0 - right / width,
        bottom=bottom / height,
        top=1.0 - top / height,
        wspace=gap_x / panel_w,
        hspace=gap_y / panel_h,
    )


def _ghosts(ax: plt.Axes, ghosts: Any, label: str | None) -> None:
    g = np.asarray(ghosts, dtype=float).reshape(-1, 2)
    if len(g):
        ax.plot(g[:, 0], g[:, 1], "x", ms=4, color="k", alpha=0.6, label=label, zorder=4)


def trajectory_figure(world: WorldMap, record: dict[str, Any], title: str | None = None):
    """One trial on the map: its true path, start and ghosts (where the acting neuron changed);
    returns the figure (TensorBoard takes figures)."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    draw_map(ax, world)
    _draw_xy(ax, record["path"], color="tab:blue", label="path")
    _start(ax, record["path"])
    _ghosts(ax, record.get("ghosts", []), "ghosts (acting neuron changed)")
    ax.set_title(
        title
        or f"trial {record.get('trial', '')}: {record['steps']} actions, "
        f"total {record['total_reinforcement']:.2f}"
    )
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


def drive_figure(result: dict[str, Any], world: WorldMap, out: Path, title: str | None = None):
    """The reflex's trial (``symrl drive``): true path, odometry path and the robot at the start."""
    from symrl.world.render import draw_path, draw_robot

    fig, ax = plt.subplots(figsize=(6.0, 5.5), dpi=120)
    draw_map(ax, world)
    draw_path(ax, result["odometry_path"], color="0.55", markers=False, label="odometry", ls=":")
    draw_path(ax, result["path"], label="true path")
    draw_robot(ax, result["start"])
    _start(ax, result["path"])
    ax.legend(loc="upper left", fontsize=8)
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)
    return out


def plot_plan(world: WorldMap, plan: Plan, walk: np.ndarray, path: Path | str) -> None:
    """The shortest path (with its clearance band) and the 0.20 m walk that follows it."""
    fig, ax = plt.subplots(figsize=(6, 6))
    draw_map(ax, world)
    pts = plan.points
    ax.plot(pts[:, 0], pts[:, 1], color="tab:red", lw=2, label=f"shortest path {plan.length:.2f} m")
    ax.plot(
        walk[:, 0],
        walk[:, 1],
        "o",
        ms=3,
        color="tab:blue",
        label=f"{len(walk) - 1} moves of {plan.step:.2f} m",
    )
    for x, y in walk[:: max(1, len(walk) // 8)]:
        ax.add_patch(plt.Circle((x, y), plan.clearance, fill=False, ec="0.6", lw=0.5))
    ax.set_title(f"Optimum: {plan.actions} actions (clearance {plan.clearance:.3f} m)")
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_reward_optimum(world: WorldMap, result: dict[str, Any], path: Path | str) -> None:
    """The best-total path of ``symrl plan --reward`` (one dot per action, red where a sonar
    reads below d_c) beside the shortest path's walk."""
    fig, ax = plt.subplots(figsize=(6, 6))
    draw_map(ax, world)
    short = result.get("shortest_path") or {}
    if short.get("path"):
        xy = np.asarray(short["path"])
        ax.plot(
            xy[:, 0],
            xy[:, 1],
            "-",
            color="0.55",
            lw=1,
            label=f"shortest path: {short['actions']} actions, "
            f"total {short['total_reinforcement']:.2f}",
        )
    xy = np.asarray(result["path"])
    near = np.asarray(result["per_action"]["f1"]) < 0
    ax.plot(
        xy[:, 0],
        xy[:, 1],
        "-",
        color="tab:blue",
        lw=1.5,
        label=f"best total found: {result['actions']} actions, "
        f"total {result['total_reinforcement']:.2f}",
    )
    ax.plot(xy[1:][~near, 0], xy[1:][~near, 1], "o", ms=3, color="tab:blue")
    ax.plot(xy[1:][near, 0], xy[1:][near, 1], "o", ms=4, color="tab:red", label="f1 < 0")
    _start(ax, xy, None)
    ax.set_title(
        f"Best total reinforcement: {result['total_reinforcement']:.3f} "
        f"(f1 {result['f1_walls']:.2f}, f2 {result['f2_heading']:.2f})"
    )
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_ladder_worlds(
    entries: Sequence[Mapping[str, Any]], path: Path | str, top: float = 2.5
) -> None:
    """Grouped bars: per world, each recipe's actions over the last trials divided by the
    world's optimum (mean over sets, sd as the error bar); 1 is the optimum. Bars above ``top``
    are cut there and labelled with their value; a number over a bar counts its failed trials
    (from trial 5 on)."""
    worlds = list(dict.fromkeys(e["world"] for e in entries))
    recipes = list(dict.fromkeys(e["recipe"] for e in entries))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(worlds) + 2.5), 4.2))
    width = 0.8 / max(len(recipes), 1)
    labelled: set[str] = set()
    for e in entries:
        i, j = recipes.index(e["recipe"]), worlds.index(e["world"])
        x = j + (i - (len(recipes) - 1) / 2) * width
        ratio = min(e["ratio"], top)
        ax.bar(
            x, ratio, width, color=f"C{i}", label=None if e["recipe"] in labelled else e["recipe"]
        )
        labelled.add(e["recipe"])
        cut = e["ratio"] > top
        if cut:
            ax.text(x, top, f"{e['ratio']:.1f}", ha="center", va="bottom", fontsize=7)
        else:
            ax.errorbar(x, ratio, yerr=e["ratio_sd"], color="black", lw=0.8, capsize=2)
        if e.get("failed_from"):
            ax.text(
                x,
                top * 0.97 if cut else ratio + e["ratio_sd"] + 0.03,
                f"✗{e['failed_from']}",
                ha="center",
                va="top" if cut else "bottom",
                fontsize=6,
                color="white" if cut else "tab:red",
                rotation=90,
            )
    ax.axhline(1.0, color="black", lw=0.8, ls="--", label="optimum (planner)")
    slanted = len(worlds) > 4
    ax.set_xticks(
        range(len(worlds)),
        worlds,
        rotation=20 if slanted else 0,
        ha="right" if slanted else "center",
    )
    ax.set_ylabel("actions, last 5 trials / optimum")
    ax.set_ylim(0, top * 1.12)
    ax.set_title("The knowledge ladder per world (mean over sets ± sd; ✗ failed trials from 5)")
    ax.legend(fontsize=8, ncol=2, loc="upper left")
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_paths(
    world: WorldMap,
    panels: Sequence[tuple[str, Iterable[Any] | Mapping[str, Any], Iterable[Any]]],
    path: Path | str,
    columns: int = 3,
) -> None:
    """One map per panel: (title, paths, ghost point sets); paths as lines from a start marker
    (a mapping ``{label: path}`` names them in the legend), ghosts as crosses. Panels without
    any path are left out; a panel count one more than ``columns`` goes in one row, not two
    rows with an empty panel."""
    named: list[tuple[str, dict[Any, Any], Iterable[Any]]] = [
        (t, dict(p) if isinstance(p, Mapping) else dict(enumerate(p)), g) for t, p, g in panels
    ]
    named = [p for p in named if any(len(np.asarray(xy).reshape(-1, 2)) for xy in p[1].values())]
    n = max(len(named), 1)
    cols = min(columns, n)
    if n % cols and n <= columns + 1:
        cols = n
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.5 * cols, 4.6 * rows), squeeze=False)
    for ax in axes.flat[len(named) :]:
        ax.set_visible(False)
    for ax, (title, paths, ghosts) in zip(axes.flat, named, strict=False):
        draw_map(ax, world)
        for i, (name, xy) in enumerate(paths.items()):
            _draw_xy(
                ax, xy, color=f"C{(i + 3) % 10}", label=name if isinstance(name, str) else None
            )
            _start(ax, xy, label="start" if i == 0 else None)
        for j, g in enumerate(ghosts):
            _ghosts(ax, g, "ghosts" if j == 0 else None)
        ax.set_title(title, fontsize=9)
        ax.legend(loc="upper left", fontsize=7)
    _fixed_margins(fig, rows, cols, left=0.65, bottom=0.55, top=0.35, gap_x=0.8, gap_y=0.9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_curves(
    curves: dict[str, np.ndarray],
    path: Path | str,
    reference: dict[str, float] | None = None,
    title: str = "",
) -> None:
    """Learning curves (one panel per quantity): mean over sets with min-max bars (Figs 7-9).

    ``curves[name]`` is (sets, trials); ``reference[name]`` draws a dashed line (paper / optimum).
    """
    names = list(curves)
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.4), squeeze=False)
    for ax, name in zip(axes[0], names, strict=False):
        v = np.asarray(curves[name], dtype=float)
        trials = np.arange(1, v.shape[1] + 1)
        mean = np.nanmean(v, axis=0)
        lo, hi = np.nanmin(v, axis=0), np.nanmax(v, axis=0)
        ax.errorbar(trials, mean, yerr=[mean - lo, hi - mean], fmt="o-", ms=3, capsize=2)
        refs = [(k, v) for k, v in (reference or {}).items() if k.startswith(name + ":")]
        for i, (label, value) in enumerate(refs):  # labels alternate ends so they never overlap
            ax.axhline(value, ls="--", lw=1, color="0.4")
            ax.annotate(
                label.split(":", 1)[1],
                (trials[-1] if i % 2 == 0 else trials[0], value),
                fontsize=7,
                ha="right" if i % 2 == 0 else "left",
                va="bottom",
                color="0.3",
            )
        ax.set_xlabel("trial")
        ax.set_ylabel(name.replace("_", " "))
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if title:
        fig.suptitle(title)
    _fixed_margins(
        fig, 1, len(names), left=0.75, bottom=0.55, top=0.55 if title else 0.3, gap_x=0.85
    )
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _comparison_row(
    axes: Sequence[Any], curves: dict[str, dict[str, np.ndarray]], quantities: Sequence[str]
) -> None:
    """Per quantity (one axis each), each recipe's mean over sets (shaded min-max)."""
    n_recipes = len(curves)
    for ax, q in zip(axes, quantities, strict=False):
        for i, (recipe, per_q) in enumerate(curves.items()):
            v = np.asarray(per_q[q], dtype=float)
            # a small offset per recipe: recipes whose curves coincide stay visible
            trials = np.arange(1, v.shape[1] + 1) + 0.08 * (i - (n_recipes - 1) / 2)
            ax.plot(
                trials,
                np.nanmean(v, axis=0),
                marker=_MARKERS[i % len(_MARKERS)],
                ms=3,
                ls=_STYLES[i % len(_STYLES)],
                color=f"C{i}",
                label=recipe,
            )
            ax.fill_between(
                trials, np.nanmin(v, axis=0), np.nanmax(v, axis=0), color=f"C{i}", alpha=0.10
            )
        ax.set_xlabel("trial")
        ax.set_ylabel(q.replace("_", " "))
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].legend(fontsize=7)


def plot_comparison(
    curves: dict[str, dict[str, np.ndarray]], path: Path | str, quantities: Sequence[str]
) -> None:
    """All recipes on one figure: per quantity, each recipe's mean over sets (shaded min-max)."""
    n = len(quantities)
    fig, axes = plt.subplots(1, n, figsize=(4.4 * n, 3.6), squeeze=False)
    _comparison_row(axes[0], curves, quantities)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_map_comparison(
    curves: dict[str, dict[str, dict[str, np.ndarray]]],
    path: Path | str,
    quantities: Sequence[str],
) -> None:
    """One row per map (``curves[map][recipe][quantity]``, sets x trials): the recipes' mean
    curves on that map, as :func:`plot_comparison` draws them."""
    n, rows = len(quantities), len(curves)
    fig, axes = plt.subplots(rows, n, figsize=(4.4 * n, 3.4 * rows), squeeze=False)
    for row, (name, per_recipe) in zip(axes, curves.items(), strict=True):
        _comparison_row(row, per_recipe, quantities)
        row[0].set_title(name, loc="left", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_baseline(results: list[dict[str, Any]], path: Path | str, title: str) -> None:
    """A baseline's runs: success rate over the last 20 episodes, and every episode's total."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for i, res in enumerate(results):
        reached = np.array([r["reached_goal"] for r in res["rows"]], dtype=float)
        ret = np.array([r["total_reinforcement"] for r in res["rows"]])
        w = min(20, len(reached))
        ep = np.arange(w, len(reached) + 1)
        axes[0].plot(
            ep,
            np.convolve(reached, np.ones(w), "valid") / w,
            color=f"C{i}",
            label=f"seed {res['seed']}",
        )
        axes[1].plot(np.arange(1, len(ret) + 1), ret, ".", ms=2, color=f"C{i}")
    axes[0].axhline(0.8, ls="--", color="0.5", lw=1)
    axes[0].set(xlabel="episode (trial)", ylabel="success rate, last 20", ylim=(-0.05, 1.05))
    axes[1].axhline(-6.24, ls="--", color="0.5", lw=1, label="paper, last trial")
    axes[1].set(xlabel="episode (trial)", ylabel="total reinforcement")
    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _log_binned(values: np.ndarray, exact: int = 20, ratio: float = 1.3):
    """Trials 1..``exact`` as they are, then means over bins growing by ``ratio`` (x: the
    bin's middle trial): a curve of thousands of trials stays readable on a log axis."""
    n = len(values)
    xs = list(np.arange(1, min(exact, n) + 1, dtype=float))
    ys = list(values[: min(exact, n)])
    lo = exact
    while lo < n:
        hi = min(n, max(lo + 1, int(round(lo * ratio))))
        xs.append(float(np.sqrt((lo + 1) * hi)))
        ys.append(float(np.mean(values[lo:hi])))
        lo = hi
    return np.array(xs), np.array(ys)


def plot_learning_curves(
    curves: dict[str, Sequence[Sequence[dict[str, Any]]]],
    path: Path | str,
    title: str = "",
    optimum: float | None = None,
) -> None:
    """Learners on one axis per quantity, trials on a log scale: ``curves[label]`` is one trial
    table (rows with ``steps``, ``total_reinforcement``, ``reached_goal``) per seed; drawn is
    the mean over the seeds that ran each trial (beyond trial 20, over log-spaced bins)."""
    quantities = (
        ("steps", "actions per trial"),
        ("total_reinforcement", "total reinforcement per trial"),
        ("reached_goal", "reached the goal (fraction of seeds)"),
    )
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.0))
    for i, (label, runs) in enumerate(curves.items()):
        lengths = sorted({len(r) for r in runs})
        seeds = f"{len(runs)} seeds" + "".join(
            f"; {sum(len(r) >= n for r in runs)} to trial {n}" for n in lengths[1:]
        )
        for ax, (key, _) in zip(axes, quantities, strict=True):
            v = np.full((len(runs), lengths[-1]), np.nan)
            for k, run in enumerate(runs):  # a seed that ran fewer trials is missing after
                v[k, : len(run)] = [float(row[key]) for row in run]
            x, y = _log_binned(np.nanmean(v, axis=0))
            ax.plot(
                x,
                y,
                marker=_MARKERS[i % len(_MARKERS)],
                ms=3,
                lw=1.2,
                ls=_STYLES[i % len(_STYLES)],
                color=f"C{i}",
                label=f"{label} ({seeds})",
            )
    for ax, (_, name) in zip(axes, quantities, strict=True):
        ax.set_xscale("log")
        ax.axvline(20, ls=":", lw=1, color="0.5")
        ax.set(xlabel="trial (log scale; dotted: the paper's 20)", ylabel=name)
    if optimum is not None:
        axes[0].axhline(
            optimum, ls="--", lw=1, color="0.4", label=f"shortest path ({optimum:g} actions)"
        )
    axes[2].set_ylim(-0.05, 1.05)
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


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


_CROSSING_COLOURS = {1: ("tab:green", "seen open"), 2: ("tab:red", "seen blocked")}


def crossings_figure(world: WorldMap, records: Sequence[dict[str, Any]], panels: int = 6):
    """Where a robot believed each border could be crossed, trial by trial: up to ``panels``
    trials of ``records`` (the first, the last and some between), each with its path and its
    crossing evidence along the region rules' borders, over the true doors (the passages a map
    tool finds in the walls: drawn for the reader, never told to the robot)."""
    from symrl.knowledge.borders import region_borders
    from symrl.knowledge.subgoals import find_passages

    borders = region_borders(world.regions)
    picks = sorted({0, len(records) - 1, *np.linspace(0, len(records) - 1, panels).astype(int)})
    picks = picks[:panels] if len(picks) > panels else picks
    cols = min(3, len(picks))
    rows = (len(picks) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 4.2 * rows), squeeze=False)
    doors = find_passages(world)
    xmin, xmax, ymin, ymax = world.bounds
    for ax, i in zip(axes.flat, picks, strict=False):
        record = records[i]
        draw_map(ax, world)
        for p in doors:
            a, b = (p.intercept, p.lo), (p.intercept, p.hi)
            if p.axis == 1:
                a, b = (p.lo, p.intercept), (p.hi, p.intercept)
            ax.plot(
                *zip(a, b, strict=True),
                color="gold",
                lw=11,
                alpha=0.5,
                solid_capstyle="butt",
                zorder=1,
                label="true door (map, not told)" if p is doors[0] else None,
            )
        for border, runs in zip(borders, record.get("stretches", []), strict=False):
            for t0, t1, state in runs:
                if state not in _CROSSING_COLOURS:
                    continue
                colour, label = _CROSSING_COLOURS[state]
                ends = zip(border.at(t0), border.at(t1), strict=True)
                ax.plot(*ends, color=colour, lw=3.5, label=label, zorder=3)
        if record.get("path"):
            _draw_xy(ax, record["path"], color="tab:blue", label="path")
        handles, labels = ax.get_legend_handles_labels()
        seen = dict(zip(labels, handles, strict=True))
        ax.legend(seen.values(), seen.keys(), loc="upper left", fontsize=7)
        ax.set_xlim(xmin - 0.3, xmax + 0.3)
        ax.set_ylim(ymin - 0.3, ymax + 0.3)
        ax.set_title(
            f"trial {record.get('trial', i + 1)}: {record['steps']} actions, "
            f"{record.get('borders_blocked', 0)} borders found blocked",
            fontsize=9,
        )
    for ax in axes.flat[len(picks) :]:
        ax.axis("off")
    fig.suptitle(f"{world.name}: where the robot believes each border can be crossed")
    fig.tight_layout()
    return fig


def plot_crossings(world: WorldMap, records: Sequence[dict[str, Any]], path: Path | str) -> None:
    """:func:`crossings_figure`, saved to ``path``."""
    fig = crossings_figure(world, records)
    fig.savefig(path, dpi=100)
    plt.close(fig)
