"""What the figures share: the map drawn under them, a path with its start marker, ghost
crosses, fixed margins in inches, and the markers and line styles that tell curves apart."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import matplotlib.pyplot as plt
import numpy as np

if TYPE_CHECKING:
    from symrl.world import WorldMap

MARKERS = "osD^vP*Xh<>"
"""A curve's marker, by its index."""
STYLES = ("-", "--", "-.", ":")
"""A curve's line style, by its index."""


def draw_map(ax: plt.Axes, world: WorldMap) -> None:
    """The world (walls, regions, goal), drawn by the world's own render module."""
    from symrl.world.render import draw_world

    draw_world(ax, world)


def draw_xy(ax: plt.Axes, xy: Any, color: str, label: str | None = None) -> None:
    """A path of (x, y) points, drawn by the world's render module."""
    from symrl.world.render import draw_path

    draw_path(ax, xy, color=color, label=label)


def start_marker(ax: plt.Axes, xy: Any, label: str | None = "start") -> None:
    """A white dot at the first point of a path."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(xy):
        ax.plot(xy[0, 0], xy[0, 1], "o", ms=6, mfc="white", mec="black", zorder=5, label=label)


def fixed_margins(
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


def ghost_marks(ax: plt.Axes, ghosts: Any, label: str | None) -> None:
    """Crosses where the acting neuron changed (the ghosts of a trial)."""
    g = np.asarray(ghosts, dtype=float).reshape(-1, 2)
    if len(g):
        ax.plot(g[:, 0], g[:, 1], "x", ms=4, color="k", alpha=0.6, label=label, zorder=4)
