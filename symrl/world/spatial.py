"""A spatial index over the walls: a step on a building costs about what it costs in a room.

:class:`CellWalls` answers the per-step queries of :class:`symrl.world.geometry.Walls` (ray
casts, sectors, clearance, the swept-disc contact) from small wall sets kept per cell of a grid
(``cell`` metres square), built the first time a robot enters the cell. A cell's set is every
wall that can be seen first from some point of the cell within ``reach`` (the sonar's range):

- walls farther than ``reach`` from the cell are dropped;
- an edge of the boundary or of an obstacle whose free side faces away from the whole cell is
  dropped (a ray from free space meets an edge from its free side first: *back-face culling*);
- a wall hidden from the whole cell behind one other wall is dropped (*occlusion culling*): if
  the eight segments from the cell's four corners to the wall's two ends all cross one wall,
  every line from the cell to it does (the set of points hiding a point is convex, and so is the
  shadow of a wall from a point).

The first wall a ray meets, the nearest wall point of a sector and the nearest wall of a point
are all seen from the point, so the culled set gives the same answers (up to rounding: the
reductions run over fewer walls). The swept-disc test uses a second, unculled set of the walls
within ``near`` of the cell (the disc leaves the cell). Robots in different cells are answered
group by group, so a robot's numbers do not depend on the batch.

Used for maps with many walls (:data:`INDEX_FROM`); the paper's world keeps its plain
``Walls`` (its trials stay bit for bit the same).
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from symrl.world.geometry import Walls
from symrl.world.worldmap import WorldMap

__all__ = ["CellWalls", "INDEX_FROM", "walls_for", "free_sides"]

INDEX_FROM = 200
"""Wall segments from which the env queries the walls through :class:`CellWalls` (below,
one ``Walls`` over all of them is as fast: a few dozen walls cost no more than the index's
bookkeeping)."""
_EMPTY = np.empty(0)


def free_sides(world: WorldMap) -> np.ndarray:
    """Per wall of ``world.segments``: +1 if the free area is on the left of the edge (from its
    first point to its second), -1 on the right, 0 for a thin wall (free on both sides)."""
    sides = []
    for ring, inside in [(world.boundary, True)] + [(p, False) for p in world.obstacles]:
        x, y = ring[:, 0], ring[:, 1]
        ccw = float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) > 0.0
        sides.append(np.full(len(ring), 1 if ccw == inside else -1, dtype=np.int8))
    sides.append(np.zeros(len(world.extra_segments), dtype=np.int8))
    return np.concatenate(sides)


def walls_for(world: WorldMap, reach: float, near: float) -> Walls | CellWalls:
    """The wall queries of ``world``'s env: one ``Walls`` below :data:`INDEX_FROM` segments,
    else a :class:`CellWalls` index."""
    segments = world.segments
    if len(segments) < INDEX_FROM:
        return Walls(segments)
    return CellWalls(segments, free_sides(world), reach, near)


class CellWalls:
    """The per-step queries of :class:`Walls` through per-cell wall sets (see the module).

    ``closest`` and ``closest_many`` return empty closest-point arrays (the per-wall points of
    a cell's set are recomputed where a query needs them); their clearance is exact up to
    ``reach`` and at least ``reach`` beyond. ``clearance`` (points, not per step) is exact.
    """

    def __init__(
        self,
        segments: np.ndarray,
        sides: np.ndarray,
        reach: float,
        near: float,
        cell: float = 0.5,
    ) -> None:
        self.all = Walls(segments)
        self.segments = self.all.segments
        self.vertices = self.all.vertices
        self.sides = np.asarray(sides, dtype=np.int8)
        self.reach = float(reach)
        self.near = float(near)
        self.cell = float(cell)
        seg = self.segments
        self._origin = (float(seg[:, [0, 2]].min()), float(seg[:, [1, 3]].min()))
        self._lines = shapely.linestrings(seg.reshape(-1, 2, 2))
        self._tree = shapely.STRtree(self._lines)
        self._cells: dict[tuple[int, int], tuple[Walls, Walls]] = {}

    def __len__(self) -> int:
        return len(self.all)

    # --- the cells ---------------------------------------------------------------------

    def _key(self, x: float, y: float) -> tuple[int, int]:
        return (
            math.floor((x - self._origin[0]) / self.cell),
            math.floor((y - self._origin[1]) / self.cell),
        )

    def _sets(self, x: float, y: float) -> tuple[Walls, Walls]:
        """(seen, near) wall sets of the cell holding (x, y), built on first use."""
        key = self._key(x, y)
        found = self._cells.get(key)
        if found is None:
            found = self._cells[key] = self._build(key)
        return found

    def cell_sizes(self) -> list[int]:
        """Walls in each built cell's seen set (for benchmarks)."""
        return [len(seen) for seen, _ in self._cells.values()]

    def _build(self, key: tuple[int, int]) -> tuple[Walls, Walls]:
        x0 = self._origin[0] + key[0] * self.cell
        y0 = self._origin[1] + key[1] * self.cell
        square = shapely.box(x0, y0, x0 + self.cell, y0 + self.cell)
        corners = np.array(
            [[x0, y0], [x0 + self.cell, y0], [x0 + self.cell, y0 + self.cell], [x0, y0 + self.cell]]
        )
        within = np.sort(self._tree.query(square, predicate="dwithin", distance=self.reach))
        nearby = np.sort(self._tree.query(square, predicate="dwithin", distance=self.near))
        seg = self.segments
        if len(within):
            s = seg[within]
            dx, dy = s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]
            # which side of each wall's line the corners are on: + left, - right
            left = dx[:, None] * (corners[None, :, 1] - s[:, 1, None]) - dy[:, None] * (
                corners[None, :, 0] - s[:, 0, None]
            )
            tol = 1e-9 * np.hypot(dx, dy)[:, None]
            side = self.sides[within][:, None]
            behind = np.all(np.where(side > 0, left < -tol, left > tol), axis=1) & (side[:, 0] != 0)
            keep = within[~behind]
            keep = keep[~self._hidden(seg[keep], seg[within], corners)]
        else:
            keep = within
        if len(keep) == 0:  # nothing in reach: the nearest wall keeps the clearance right
            keep = np.array([int(self._tree.nearest(square))])
        if len(nearby) == 0:
            nearby = keep
        return Walls(seg[keep]), Walls(seg[nearby])

    @staticmethod
    def _hidden(cand: np.ndarray, occluders: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """(m,) bool: whether each candidate wall is hidden from the whole cell by one
        occluder (the eight corner-to-end segments all cross it properly)."""
        m = len(cand)
        if m == 0:
            return np.zeros(0, dtype=bool)
        ends = cand.reshape(m, 2, 2)
        # the 8 sight lines per candidate: p (corner) -> q (end), shape (m, 8, 2)
        p = np.broadcast_to(corners[None, :, None, :], (m, 4, 2, 2)).reshape(m, 8, 2)
        q = np.broadcast_to(ends[:, None, :, :], (m, 4, 2, 2)).reshape(m, 8, 2)
        hidden = np.zeros(m, dtype=bool)
        ax, ay, bx, by = (occluders[:, i] for i in range(4))
        wx, wy = bx - ax, by - ay
        px, py = p[..., 0:1], p[..., 1:2]
        qx, qy = q[..., 0:1], q[..., 1:2]
        mx, my = qx - px, qy - py  # (m, 8, 1) against occluders (k,)
        o1 = mx * (ay - py) - my * (ax - px)
        o2 = mx * (by - py) - my * (bx - px)
        o3 = wx * (py - ay) - wy * (px - ax)
        o4 = wx * (qy - ay) - wy * (qx - ax)
        crosses = (o1 * o2 < 0.0) & (o3 * o4 < 0.0)  # (m, 8, k)
        hidden |= np.any(np.all(crosses, axis=1), axis=1)
        return hidden

    # --- the queries of one point ----------------------------------------------------------

    def closest(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray, float]:
        return _EMPTY, _EMPTY, self._sets(x, y)[0].closest(x, y)[2]

    def point_clearance(self, x: float, y: float) -> float:
        return self._sets(x, y)[0].closest(x, y)[2]

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Exact clearance of any points (over all walls; not a per-step query)."""
        return self.all.clearance(points)

    def scan(
        self,
        x: float,
        y: float,
        heading: float,
        ray_offsets: np.ndarray,
        n_sectors: int,
        ray_range: float,
        sector_range: float,
        closest: tuple[np.ndarray, np.ndarray, float] | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None, float]:
        walls = self._sets(x, y)[0] if max(ray_range, sector_range) <= self.reach else self.all
        return walls.scan(x, y, heading, ray_offsets, n_sectors, ray_range, sector_range)

    def swept_disc_contact(
        self,
        x0: float,
        y0: float,
        x1: float,
        y1: float,
        radius: float,
        clear0: float | None = None,
        clear1: float | None = None,
    ) -> bool:
        inside = math.hypot(x1 - x0, y1 - y0) + radius < self.near
        walls = self._sets(x0, y0)[1] if inside else self.all
        return walls.swept_disc_contact(x0, y0, x1, y1, radius, clear0, clear1)

    # --- the same for B points, group by group ---------------------------------------------

    def _groups(self, x: np.ndarray, y: np.ndarray) -> list[tuple[np.ndarray, tuple[Walls, Walls]]]:
        keys = [self._key(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)]
        rows: dict[tuple[int, int], list[int]] = {}
        for i, key in enumerate(keys):
            rows.setdefault(key, []).append(i)
        out = []
        for key, idx in rows.items():
            found = self._cells.get(key)
            if found is None:
                found = self._cells[key] = self._build(key)
            out.append((np.array(idx, dtype=np.intp), found))
        return out

    def closest_many(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        clear = np.empty(len(x))
        for idx, (seen, _) in self._groups(x, y):
            clear[idx] = seen.closest_many(x[idx], y[idx])[2]
        empty = np.empty((len(x), 0))
        return empty, empty, clear

    def scan_many(
        self,
        x: np.ndarray,
        y: np.ndarray,
        heading: np.ndarray,
        ray_offsets: np.ndarray,
        n_sectors: int,
        ray_range: float,
        sector_range: float,
        closest: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        if max(ray_range, sector_range) > self.reach:
            return self.all.scan_many(
                x, y, heading, ray_offsets, n_sectors, ray_range, sector_range
            )
        rays = np.empty((len(x), len(ray_offsets)))
        clear = np.empty(len(x))
        sectors: np.ndarray | None = None
        for idx, (seen, _) in self._groups(x, y):
            r, s, c = seen.scan_many(
                x[idx], y[idx], heading[idx], ray_offsets, n_sectors, ray_range, sector_range
            )
            rays[idx], clear[idx] = r, c
            if s is not None:
                if sectors is None:
                    sectors = np.full((len(x), n_sectors), sector_range)
                sectors[idx] = s
        return rays, sectors, clear

    def swept_disc_contact_many(
        self,
        x0: np.ndarray,
        y0: np.ndarray,
        x1: np.ndarray,
        y1: np.ndarray,
        radius: float,
        clear0: np.ndarray,
        clear1: np.ndarray,
    ) -> np.ndarray:
        hit = np.empty(len(x0), dtype=bool)
        far = np.hypot(x1 - x0, y1 - y0) + radius >= self.near
        for idx, (_, near) in self._groups(x0, y0):
            walls = self.all if far[idx].any() else near
            hit[idx] = walls.swept_disc_contact_many(
                x0[idx], y0[idx], x1[idx], y1[idx], radius, clear0[idx], clear1[idx]
            )
        return hit
