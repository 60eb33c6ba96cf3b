"""A lower bound of the path length to the goal that knows the walls: the lazy A*'s heuristic.

The straight line to the goal rim knows no wall: on a 5,230-corner floor it says 79 m where the
way is 168 m, and A* opened a third of the floor's corners. :class:`GridBound` is the length of
the shortest way to the goal disc on a grid of cells, through every cell that *could* hold the
robot's centre, shrunk by the grid's largest excess over a straight line and a few cells' slack,
so that it stays below the true length (an admissible heuristic; not a consistent one: the lazy
search re-opens a node it reaches again shorter).

Cells. A cell is blocked only if no point in it can be ``r`` clear of the walls: every wall is
sampled densely and marks the cells its points fall in; a point of a cell is then at most
``d + 2 h`` from a wall, where ``d`` is the distance between the cell's centre and the nearest
marked centre and ``h`` half a cell diagonal, so a cell with ``d < r - 2 h`` holds no free point.
Every other cell is open (outside the map too: the walls close the inside off). The free space is
inside the open cells, so a path there is a path through open cells.

Distances. Dijkstra (scipy) on the open cells joined to their 16 nearest neighbours (king and
knight moves), from every open cell that may hold a point of the goal disc. Along a straight
segment such moves cover the cells it crosses in at most ``KNIGHT_EXCESS`` times its length,
plus about a cell at each end; the bound divides by that and gives up a slack for the bends
(:data:`SLACK_SHARE` of the length) and the ends (:data:`SLACK_CELLS` cells). That is an
argument, not a proof; measured, the bound is at least 7 % below the true length from random
free points of the benchmark floors (``docs/journal/buildings.md``).
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from symrl.world import WorldMap
from symrl.world.geometry import Walls

__all__ = ["GridBound", "grid_bound", "KNIGHT_EXCESS"]

KNIGHT_EXCESS = math.sqrt(10.0 - 4.0 * math.sqrt(5.0))
"""Largest ratio of the 16-neighbour grid length to the straight line (1.0275): between the
moves (1, 0) and (2, 1) the ratio is at most the norm of the ``n`` with ``n . (1, 0) = 1`` and
``n . (2, 1) = sqrt(5)``; between (2, 1) and (1, 1) it is smaller (1.013)."""
SLACK_SHARE = 0.05
"""Share of the grid length given up for the cells a way crosses at its bends."""
SLACK_CELLS = 4.0
"""Cells given up at the two ends of a way (a start or goal anywhere in its cell)."""
MAX_CELLS = 2_000_000
"""At most this many cells: a larger map gets larger cells (a looser bound, still below)."""

_MOVES = ((0, 1), (1, 0), (1, 1), (1, -1), (1, 2), (2, 1), (1, -2), (2, -1))


class GridBound:
    """Lower bound of the length of a path keeping ``r`` from every wall from a point to the
    goal disc ``(g, rg)``: :meth:`at`; ``inf`` where no open cell leads to the goal."""

    def __init__(self, world: WorldMap, r: float, g: np.ndarray, rg: float) -> None:
        seg = Walls(world.segments).segments.reshape(-1, 4)
        lo = seg.reshape(-1, 2).min(axis=0)
        hi = seg.reshape(-1, 2).max(axis=0)
        span = hi - lo
        cell = max(r / 2.6, math.sqrt(float(span[0] * span[1]) / MAX_CELLS), 1e-3)
        self.cell, self.r = cell, r
        self.x0, self.y0 = float(lo[0] - 2 * cell), float(lo[1] - 2 * cell)
        self.nx = int(math.ceil(span[0] / cell)) + 4
        self.ny = int(math.ceil(span[1] / cell)) + 4
        open_ = self._open_cells(seg)
        ids = np.full(open_.shape, -1, dtype=np.int32)
        ids[open_] = np.arange(int(open_.sum()), dtype=np.int32)
        dist = np.full(self.ny * self.nx, math.inf)
        sources = ids.ravel()[self._goal_cells(g, rg)]
        sources = sources[sources >= 0]
        if len(sources):
            d = csgraph.dijkstra(self._graph(open_, ids), indices=sources, min_only=True)
            dist[np.flatnonzero(open_.ravel())] = d
        scale = (1.0 - SLACK_SHARE) / KNIGHT_EXCESS
        self.values = np.maximum(0.0, dist * scale - SLACK_CELLS * cell)
        """Per cell (row-major, rows along y): the bound for every point of the cell."""

    def _open_cells(self, seg: np.ndarray) -> np.ndarray:
        """Cells that may hold a point ``r`` clear of the walls (module docstring)."""
        cell = self.cell
        length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
        n = np.ceil(length / (cell / 3)).astype(np.int64) + 2
        which = np.repeat(np.arange(len(seg)), n)
        first = np.repeat(np.cumsum(n) - n, n)
        t = (np.arange(len(which)) - first) / (n[which] - 1)
        px = seg[which, 0] + t * (seg[which, 2] - seg[which, 0])
        py = seg[which, 1] + t * (seg[which, 3] - seg[which, 1])
        marked = np.zeros((self.ny, self.nx), dtype=bool)
        col = np.clip(((px - self.x0) / cell).astype(np.int64), 0, self.nx - 1)
        row = np.clip(((py - self.y0) / cell).astype(np.int64), 0, self.ny - 1)
        marked[row, col] = True
        d = ndimage.distance_transform_edt(~marked) * cell
        return np.asarray(d >= self.r - math.sqrt(2.0) * cell - 1e-6)

    def _goal_cells(self, g: np.ndarray, rg: float) -> np.ndarray:
        """Flat indices of the cells that may hold a point of the goal disc."""
        cell, half = self.cell, self.cell * math.sqrt(0.5)
        c0 = max(0, int((g[0] - rg - self.x0) // cell) - 1)
        c1 = min(self.nx, int((g[0] + rg - self.x0) // cell) + 2)
        r0 = max(0, int((g[1] - rg - self.y0) // cell) - 1)
        r1 = min(self.ny, int((g[1] + rg - self.y0) // cell) + 2)
        rows, cols = np.mgrid[r0:r1, c0:c1]
        cx, cy = self.x0 + (cols + 0.5) * cell, self.y0 + (rows + 0.5) * cell
        near = np.hypot(cx - g[0], cy - g[1]) <= rg + half
        return (rows * self.nx + cols)[near]

    def _graph(self, open_: np.ndarray, ids: np.ndarray) -> sparse.csr_matrix:
        """Open cells joined both ways to their open king and knight neighbours (edge: the
        centres' distance), built row by row as a CSR matrix."""
        ny, nx = open_.shape
        pad = 2
        grid = np.full((ny + 2 * pad, nx + 2 * pad), -1, dtype=np.int32)
        grid[pad : pad + ny, pad : pad + nx] = ids
        moves = [m for di, dj in _MOVES for m in ((di, dj), (-di, -dj))]
        where = open_
        nbr = np.stack(
            [grid[pad + di : pad + di + ny, pad + dj : pad + dj + nx][where] for di, dj in moves],
            axis=1,
        )
        weight = np.array([self.cell * math.hypot(di, dj) for di, dj in moves])
        ok = nbr >= 0
        indptr = np.zeros(len(nbr) + 1, dtype=np.int64)
        np.cumsum(ok.sum(axis=1), out=indptr[1:])
        data = np.broadcast_to(weight, nbr.shape)[ok]
        n = len(nbr)
        return sparse.csr_matrix((data, nbr[ok], indptr), shape=(n, n))

    def at(self, x: float, y: float) -> float:
        """The bound at point ``(x, y)`` (0 off the grid: no bound known there)."""
        col = int((x - self.x0) // self.cell)
        row = int((y - self.y0) // self.cell)
        if not (0 <= col < self.nx and 0 <= row < self.ny):
            return 0.0
        return float(self.values.item(row * self.nx + col))


_BOUNDS: dict[int, tuple[weakref.ref, dict[tuple[float, float, float, float], GridBound]]] = {}
"""The bounds built in this process, by the map object's id (as ``path_checker``'s checkers)."""


def grid_bound(world: WorldMap, r: float, g: np.ndarray, rg: float) -> GridBound:
    """The :class:`GridBound` of ``world`` at clearance ``r`` to the goal disc, remembered: one
    bound serves every plan on the map at clearance ``r`` or more."""
    entry = _BOUNDS.get(id(world))
    if entry is None or entry[0]() is not world:
        if len(_BOUNDS) >= 16:
            _BOUNDS.clear()
        entry = _BOUNDS[id(world)] = (weakref.ref(world), {})
    key = (float(r), float(g[0]), float(g[1]), float(rg))
    bound = entry[1].get(key)
    if bound is None:
        bound = entry[1][key] = GridBound(world, r, g, rg)
    return bound
