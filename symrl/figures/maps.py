"""The figures drawn on the map: one trial, the reflex's drive, the shortest path, the
reward's optimum, a study's paths, and where the robot believes the borders can be crossed."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np

if TYPE_CHECKING:
    from symrl.knowledge.planner import Plan
    from symrl.world import WorldMap

from symrl.figures.parts import draw_map, draw_xy, fixed_margins, ghost_marks, start_marker


def trajectory_figure(world: WorldMap, record: dict[str, Any], title: str | None = None):
    """One trial on the map: its true path, start and ghosts (where the acting neuron changed);
    returns the figure (TensorBoard takes figures)."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    draw_map(ax, world)
    draw_xy(ax, record["path"], color="tab:blue", label="path")
    start_marker(ax, record["path"])
    ghost_marks(ax, record.get("ghosts", []), "ghosts (acting neuron changed)")
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
    start_marker(ax, result["path"])
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
    start_marker(ax, xy, None)
    ax.set_title(
        f"Best total reinforcement: {result['total_reinforcement']:.3f} "
        f"(f1 {result['f1_walls']:.2f}, f2 {result['f2_heading']:.2f})"
    )
    ax.legend(loc="upper left", fontsize=8)
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
            draw_xy(ax, xy, color=f"C{(i + 3) % 10}", label=name if isinstance(name, str) else None)
            start_marker(ax, xy, label="start" if i == 0 else None)
        for j, g in enumerate(ghosts):
            ghost_marks(ax, g, "ghosts" if j == 0 else None)
        ax.set_title(title, fontsize=9)
        ax.legend(loc="upper left", fontsize=7)
    fixed_margins(fig, rows, cols, left=0.65, bottom=0.55, top=0.35, gap_x=0.8, gap_y=0.9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


_CROSSING_COLOURS = {
    1: ("tab:green", "seen open"),
    2: ("tab:red", "seen blocked"),
    3: ("tab:purple", "led into a dead end"),
}


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
            draw_xy(ax, record["path"], color="tab:blue", label="path")
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
