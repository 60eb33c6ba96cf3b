"""Shared matplotlib figures of the studies: paths on the map, learning curves, comparisons.

The map itself is drawn by ``symrl.world.render.draw_world`` (the world's own drawing); these
functions only add what a study shows on top of it. Every function writes one PNG and closes its
figure, so long studies do not accumulate open figures.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if TYPE_CHECKING:
    from symrl.studies.planner import Plan
    from symrl.world import WorldMap

__all__ = ["draw_map", "plot_plan", "plot_paths", "plot_curves", "plot_comparison"]


def draw_map(ax: plt.Axes, world: WorldMap) -> None:
    """The world (walls, regions, goal), drawn by the world's own render module."""
    from symrl.world.render import draw_world

    draw_world(ax, world)


def _draw_xy(ax: plt.Axes, xy: np.ndarray, color: str, label: str | None = None) -> None:
    from symrl.world.render import draw_path

    draw_path(ax, xy, color=color, label=label)


def plot_plan(world: WorldMap, plan: Plan, walk: np.ndarray, path: Path | str) -> None:
    """The shortest path (with its clearance band) and the 0.20 m walk that follows it."""
    fig, ax = plt.subplots(figsize=(6, 6))
    draw_map(ax, world)
    pts = plan.points
    ax.plot(pts[:, 0], pts[:, 1], color="tab:red", lw=2, label=f"shortest path {plan.length:.2f} m")
    ax.plot(walk[:, 0], walk[:, 1], "o", ms=3, color="tab:blue",
            label=f"{len(walk) - 1} moves of {plan.step:.2f} m")
    for x, y in walk[:: max(1, len(walk) // 8)]:
        ax.add_patch(plt.Circle((x, y), plan.clearance, fill=False, ec="0.6", lw=0.5))
    ax.set_title(f"Optimum: {plan.actions} actions (clearance {plan.clearance:.3f} m)")
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def plot_paths(
    world: WorldMap,
    panels: Sequence[tuple[str, Iterable[np.ndarray], Iterable[np.ndarray]]],
    path: Path | str,
    columns: int = 3,
) -> None:
    """One map per panel: (title, paths, ghost point sets); paths as lines, ghosts as crosses."""
    n = len(panels)
    cols = min(columns, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.5 * cols, 4.6 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, (title, paths, ghosts) in zip(axes.flat, panels, strict=False):
        draw_map(ax, world)
        for i, xy in enumerate(paths):
            _draw_xy(ax, xy, color=f"C{(i + 3) % 10}")
        for g in ghosts:
            g = np.asarray(g, dtype=float).reshape(-1, 2)
            if len(g):
                ax.plot(g[:, 0], g[:, 1], "x", ms=4, color="k", alpha=0.6)
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
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
            ax.annotate(label.split(":", 1)[1], (trials[-1] if i % 2 == 0 else trials[0], value),
                        fontsize=7, ha="right" if i % 2 == 0 else "left", va="bottom", color="0.3")
        ax.set_xlabel("trial")
        ax.set_ylabel(name.replace("_", " "))
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def plot_comparison(
    curves: dict[str, dict[str, np.ndarray]], path: Path | str, quantities: Sequence[str]
) -> None:
    """All recipes on one figure: per quantity, each recipe's mean over sets (shaded min-max)."""
    n = len(quantities)
    fig, axes = plt.subplots(1, n, figsize=(4.4 * n, 3.6), squeeze=False)
    for ax, q in zip(axes[0], quantities, strict=False):
        for i, (recipe, per_q) in enumerate(curves.items()):
            v = np.asarray(per_q[q], dtype=float)
            trials = np.arange(1, v.shape[1] + 1)
            ax.plot(trials, np.nanmean(v, axis=0), "o-", ms=2.5, color=f"C{i}", label=recipe)
            ax.fill_between(trials, np.nanmin(v, axis=0), np.nanmax(v, axis=0),
                            color=f"C{i}", alpha=0.12)
        ax.set_xlabel("trial")
        ax.set_ylabel(q.replace("_", " "))
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
