"""Matplotlib drawing of the world: walls, region lines, goal, robot, sonar rays and paths.

The ``draw_*`` helpers take a matplotlib ``Axes`` so figures (studies, notebooks) reuse them;
:class:`EnvRenderer` uses them for ``Hailu2001Env.render``. matplotlib is imported lazily by the
renderer so the env itself never needs it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap

__all__ = [
    "draw_world",
    "draw_regions",
    "region_label_points",
    "draw_goal",
    "draw_path",
    "draw_robot",
    "draw_sonar",
    "save_map_figure",
    "EnvRenderer",
]

WALL_COLOR = "0.15"
SOLID_COLOR = "0.80"


def draw_world(ax: Any, world: WorldMap, regions: bool = True, goal: bool = True) -> None:
    """Draw the map: the solid area outside the free boundary, walls, region lines and goal.

    The obstacles and the walls are one artist each (a path, a line collection): one artist per
    wall took seconds on a building's thousands of corners."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath

    xmin, xmax, ymin, ymax = world.bounds
    pad = 0.3
    frame = np.array(
        [
            [xmin - pad, ymin - pad],
            [xmax + pad, ymin - pad],
            [xmax + pad, ymax + pad],
            [xmin - pad, ymax + pad],
        ]
    )
    # solid = frame minus the free polygon (even-odd fill of both rings)
    # matplotlib fills by nonzero winding: the free ring must wind opposite to the CCW frame
    b = world.boundary
    area = np.sum(b[:, 0] * np.roll(b[:, 1], -1) - np.roll(b[:, 0], -1) * b[:, 1])
    ring = b if area < 0 else b[::-1]
    verts = np.concatenate([frame, frame[:1], ring, ring[:1]])
    codes = (
        [MplPath.MOVETO]
        + [MplPath.LINETO] * 3
        + [MplPath.CLOSEPOLY]
        + [MplPath.MOVETO]
        + [MplPath.LINETO] * (len(world.boundary) - 1)
        + [MplPath.CLOSEPOLY]
    )
    ax.add_patch(
        PathPatch(MplPath(verts, codes), facecolor=SOLID_COLOR, edgecolor="none", zorder=0)
    )
    if len(world.obstacles):
        # each obstacle a closed subpath, each wound counter-clockwise: filled by nonzero winding
        parts = []
        for poly in world.obstacles:
            q = np.asarray(poly, dtype=float)
            turn = np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
            q = q if turn >= 0 else q[::-1]
            parts.append(MplPath(np.vstack([q, q[:1]]), closed=True))  # the last: CLOSEPOLY
        ax.add_patch(
            PathPatch(
                MplPath.make_compound_path(*parts),
                facecolor=SOLID_COLOR,
                edgecolor="none",
                zorder=0,
            )
        )
    seg = world.segments
    ax.add_collection(
        LineCollection(
            list(seg.reshape(-1, 2, 2)),
            colors=WALL_COLOR,
            linewidths=1.5,
            capstyle="round",
            zorder=1,
        ),
        autolim=False,
    )
    if regions:
        draw_regions(ax, world)
    if goal:
        draw_goal(ax, world)
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def draw_regions(ax: Any, world: WorldMap, color: str = "tab:blue", names: bool = True) -> None:
    """Draw the named region lines (paper section 6.1) as dashed lines across the map and,
    with ``names``, each region's name at a free point inside it."""
    xmin, xmax, ymin, ymax = world.bounds
    for name, (axis, value) in world.regions.lines.items():
        if axis == "x":
            ax.plot([value, value], [ymin, ymax], ls="--", lw=0.8, color=color, zorder=1)
            ax.text(value, ymax, f" {name}", color=color, fontsize=8, va="bottom", ha="left")
        else:
            ax.plot([xmin, xmax], [value, value], ls="--", lw=0.8, color=color, zorder=1)
            ax.text(xmin, value, f"{name} ", color=color, fontsize=8, va="center", ha="right")
    if names:
        for region, (x, y) in region_label_points(world).items():
            # above the paths, on a light box: a path through a label never hides it
            ax.text(
                x,
                y,
                region,
                color=color,
                fontsize=8,
                ha="center",
                va="center",
                zorder=6,
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7},
            )


def region_label_points(world: WorldMap, grid: int = 40) -> dict[str, tuple[float, float]]:
    """A free point inside each region, near the middle of its free area (for labels)."""
    xmin, xmax, ymin, ymax = world.bounds
    grid_x, grid_y = np.meshgrid(np.linspace(xmin, xmax, grid), np.linspace(ymin, ymax, grid))
    xs, ys = grid_x.ravel(), grid_y.ravel()
    free = world.in_free_area(xs, ys)
    points: dict[str, list[tuple[float, float]]] = {}
    names = world.regions.regions_of(xs[free], ys[free])  # one call for the ~1,000 points
    for x, y, name in zip(xs[free].tolist(), ys[free].tolist(), names, strict=True):
        points.setdefault(name, []).append((x, y))
    out = {}
    for region, pts in points.items():
        arr = np.array(pts)
        centre = np.median(arr, axis=0)
        x, y = arr[np.argmin(np.hypot(*(arr - centre).T))]
        out[region] = (float(x), float(y))
    return out


def draw_goal(ax: Any, world: WorldMap, color: str = "tab:green") -> None:
    """Draw the goal circle ("the big circle") and its centre."""
    from matplotlib.patches import Circle

    g = world.goal
    ax.add_patch(
        Circle((g.x, g.y), g.radius, facecolor=color, alpha=0.25, edgecolor=color, zorder=2)
    )
    ax.plot([g.x], [g.y], marker="+", color=color, zorder=2)


def draw_path(
    ax: Any,
    xy: Sequence[Sequence[float]] | np.ndarray,
    color: str = "tab:red",
    label: str | None = None,
    markers: bool = True,
    **kwargs: Any,
) -> None:
    """Draw a path of (x, y) points, with a dot at each step when ``markers``."""
    pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return
    ax.plot(
        pts[:, 0],
        pts[:, 1],
        color=color,
        lw=1.2,
        label=label,
        marker="." if markers else None,
        ms=3,
        zorder=3,
        **kwargs,
    )


def draw_robot(
    ax: Any, pose: Sequence[float] | np.ndarray, radius: float = 0.26, color: str = "tab:orange"
) -> None:
    """Draw the robot disc at ``pose`` (x, y, heading) with a heading line."""
    from matplotlib.patches import Circle

    x, y, h = (float(v) for v in pose[:3])
    ax.add_patch(Circle((x, y), radius, facecolor=color, alpha=0.5, edgecolor="k", lw=1, zorder=4))
    ax.plot([x, x + radius * np.cos(h)], [y, y + radius * np.sin(h)], color="k", lw=1.5, zorder=5)


def draw_sonar(
    ax: Any,
    pose: Sequence[float] | np.ndarray,
    readings: np.ndarray,
    radius: float = 0.26,
    color: str = "tab:purple",
) -> None:
    """Draw sonar rays from the rim: ray k at heading + 2*pi*k/n, length = rim reading (metres)."""
    x, y, h = (float(v) for v in pose[:3])
    r = np.asarray(readings, dtype=np.float64)
    ang = h + 2.0 * np.pi * np.arange(len(r)) / len(r)
    c, s = np.cos(ang), np.sin(ang)
    x0, y0 = x + radius * c, y + radius * s
    x1, y1 = x + (radius + r) * c, y + (radius + r) * s
    ax.plot(np.stack([x0, x1]), np.stack([y0, y1]), color=color, lw=0.5, alpha=0.6, zorder=3)


def save_map_figure(
    world: WorldMap,
    out: Any,
    path: Sequence[Sequence[float]] | np.ndarray | None = None,
    title: str | None = None,
    subgoals: Sequence[Sequence[float]] | np.ndarray | None = None,
) -> None:
    """One PNG of a map for the docs: walls, region lines and names, goal, the robot at its start
    and, when given, a path (e.g. the planner's optimum) and sub-goal points."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width = 6.0
    height = max(2.5, width * _aspect(world)) + 0.4
    fig = Figure(figsize=(width, height), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    draw_world(ax, world)
    if path is not None:
        draw_path(ax, path, markers=False, label="shortest path")
    if subgoals is not None and len(subgoals):
        pts = np.asarray(subgoals, dtype=np.float64).reshape(-1, 2)
        ax.plot(pts[:, 0], pts[:, 1], "x", color="tab:purple", ms=5, zorder=4, label="sub-goals")
    s = world.start
    draw_robot(ax, (s.x, s.y, s.heading))
    if path is not None or subgoals is not None:
        ax.legend(loc="best", fontsize=7)
    ax.set_title(title or world.name, fontsize=9)
    fig.tight_layout()
    fig.savefig(out)


ASPECT_RANGE = (0.25, 2.0)
"""Height over width of a map's figure, at least and at most: a map far taller or wider than
that (1.2 m x 9 km) is drawn squeezed, in a frame of at most 6 x 12 inches, instead of a frame
of gigabytes or of no rows at all."""


def _aspect(world: WorldMap) -> float:
    xmin, xmax, ymin, ymax = world.bounds
    low, high = ASPECT_RANGE
    return min(max((ymax - ymin + 0.6) / (xmax - xmin + 0.6), low), high)


class EnvRenderer:
    """One matplotlib figure for an env: Agg canvas for rgb_array, a pyplot window for human."""

    def __init__(
        self, world: WorldMap, robot: RobotConfig, human: bool = False, dpi: int = 80
    ) -> None:
        try:
            import matplotlib  # noqa: F401
        except ImportError as err:  # pragma: no cover - matplotlib is a dependency
            raise ImportError("rendering needs matplotlib: pip install matplotlib") from err
        self.world, self.robot, self.human = world, robot, human
        width = 6.0
        height = width * _aspect(world)
        if human:
            import matplotlib.pyplot as plt

            plt.ion()
            self.fig = plt.figure(figsize=(width, height), dpi=dpi)
        else:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            self.fig = Figure(figsize=(width, height), dpi=dpi)
            FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_subplot(1, 1, 1)
        draw_world(self.ax, world)  # static: drawn once, the moving parts are redrawn per frame
        self.fig.tight_layout()
        self._static = set(self.ax.get_children())

    def draw(
        self,
        pose: np.ndarray,
        sonar_rim: np.ndarray,
        path: Sequence[Sequence[float]],
        odometry_path: Sequence[Sequence[float]] | None = None,
    ) -> np.ndarray:
        """Draw the robot, its sonar rays and paths over the map; return the HWC uint8 frame."""
        ax = self.ax
        for artist in ax.get_children():
            if artist not in self._static:
                artist.remove()
        if odometry_path is not None and len(odometry_path) > 1:
            draw_path(ax, odometry_path, color="0.5", markers=False, ls=":")
        draw_path(ax, path)
        draw_sonar(ax, pose, sonar_rim, self.robot.radius)
        draw_robot(ax, pose, self.robot.radius)
        self.fig.canvas.draw()
        frame = np.asarray(self.fig.canvas.buffer_rgba())[:, :, :3]  # type: ignore[attr-defined]
        # even width and height (H.264 video needs them): repeat the last row / column
        h, w = frame.shape[:2]
        frame = np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
        if self.human:
            import matplotlib.pyplot as plt

            plt.pause(0.001)
        return frame

    def close(self) -> None:
        if self.human:
            import matplotlib.pyplot as plt

            plt.close(self.fig)
        self.fig = None  # type: ignore[assignment]
