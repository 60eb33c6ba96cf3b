"""The planner's wall queries on the walls near the query only, with the same answers as on all.

:class:`symrl.world.geometry.Walls` answers every query over every wall: the planner asks
hundreds of thousands of them, so its time grew with the square of the corners (66-86 s on a
642-corner floor). Here an STRtree (shapely, in C) first picks the walls within the tested
distance plus a micrometre, and the same element-wise arithmetic as ``Walls`` runs on those
alone. A minimum over a subset that holds the true minimiser is the same float, and a subset
whose minimum is above the threshold answers the same comparison, so every answer is the one
``Walls`` gives (bit for bit where a distance is returned).

The cone test (:meth:`WallIndex.cone_ok`) rejects, without any query, a point of a corner's
circle that looks into one of the corner's own walls: such a point is closer than ``r - 1e-7``
to that wall (proved in its docstring), so it would fail the exact test anyway.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from symrl.world.geometry import Walls

__all__ = ["WallIndex", "CONE_LIMIT"]

_PAD = 1e-6
"""Metres added to a query distance: the STRtree's distances are exact to ~1e-15 m."""
_CONE = 0.01
"""Angle (rad) by which the cone test widens each corner's free cone (see ``cone_ok``)."""
_SHORT = 1e-4
"""Walls shorter than this (m) are left out of the cone test (their bound is too weak)."""
CONE_LIMIT = math.sin(_CONE) + 1e-9
NEAR_VERTEX = (3.0, 5.0, 8.0)
"""Radii (m) of the rings of walls round a corner that screen its bitangents, nearest first
(:meth:`WallIndex.crossings`; measured on a 5,230-corner floor: most hit a wall within 3 m)."""
"""Largest cosine between a free circle point's direction and one of its vertex's walls."""


class WallIndex:
    """Exact clearance, free-cone and swept-disc queries on a :class:`Walls`, walls near first."""

    def __init__(
        self, walls: Walls, r: float, near_vertex: dict[int, list[np.ndarray]] | None = None
    ) -> None:
        """``near_vertex``: :meth:`near_vertex`'s answers to share with the indexes of the same
        walls at other clearances (they do not depend on it)."""
        self.walls = walls
        self.r = r
        self.tree = shapely.STRtree(shapely.linestrings(walls.segments.reshape(-1, 2, 2)))
        self._near_circle: dict[int, np.ndarray] = {}
        self._near_vertex = {} if near_vertex is None else near_vertex
        self._cones = self._cone_directions() if r >= 0.01 else None

    # --- candidates ---------------------------------------------------------------------------

    def near_points(self, x: np.ndarray, y: np.ndarray, dist: float) -> tuple[np.ndarray, ...]:
        """(point index, wall index) of every wall within ``dist`` (+ a micrometre) of a point."""
        pairs = self.tree.query(shapely.points(x, y), predicate="dwithin", distance=dist + _PAD)
        return pairs[0], pairs[1]

    def near_circle(self, ci: int) -> np.ndarray:
        """Walls that can come within ``r`` of a point of vertex ``ci``'s circle (radius ``r``)."""
        idx = self._near_circle.get(ci)
        if idx is None:
            v = self.walls.vertices[ci]
            idx = self.tree.query(
                shapely.points(v[0], v[1]), predicate="dwithin", distance=2 * self.r + _PAD
            )
            idx = self._near_circle[ci] = np.sort(idx)
        return idx

    def near_vertex(self, ci: int) -> list[np.ndarray]:
        """:meth:`near_rings` of vertex ``ci`` (its room's walls, mostly), remembered."""
        rings = self._near_vertex.get(ci)
        if rings is None:
            rings = self._near_vertex[ci] = self.near_rings(self.walls.vertices[ci])
        return rings

    def near_rings(self, p: np.ndarray) -> list[np.ndarray]:
        """Walls near point ``p`` in rings: within the first of :data:`NEAR_VERTEX` m, then
        within the second and not the first, and so on."""
        v = shapely.points(float(p[0]), float(p[1]))
        seen: np.ndarray = np.zeros(0, dtype=np.intp)
        rings = []
        for dist in NEAR_VERTEX:
            idx = np.sort(self.tree.query(v, predicate="dwithin", distance=dist))
            rings.append(np.setdiff1d(idx, seen, assume_unique=True))
            seen = idx
        return rings

    def crossings(self, seg: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """Which motions ``(m, 4)`` properly cross one of the walls ``idx`` (the crossing test
        of :meth:`swept_contacts`, same floats): such a motion touches that wall."""
        if len(seg) == 0 or len(idx) == 0:
            return np.zeros(len(seg), dtype=bool)
        w = self.walls
        ax, ay, bx, by = w.ax[idx], w.ay[idx], w.bx[idx], w.by[idx]
        dx, dy = w.dx[idx], w.dy[idx]
        x0, y0, x1, y1 = (seg[:, k : k + 1] for k in range(4))
        mx, my = x1 - x0, y1 - y0
        o1 = mx * (ay - y0) - my * (ax - x0)
        o2 = mx * (by - y0) - my * (bx - x0)
        o3 = dx * (y0 - ay) - dy * (x0 - ax)
        o4 = dx * (y1 - ay) - dy * (x1 - ax)
        return np.any((o1 * o2 < 0.0) & (o3 * o4 < 0.0), axis=1)

    # --- clearances (the formulas of Walls, on a subset) -------------------------------------

    def point_clearance_ge(self, x: float, y: float, limit: float) -> bool:
        """``Walls.point_clearance(x, y) >= limit`` (``limit`` <= ``r``), walls near first."""
        idx = self.tree.query(shapely.points(x, y), predicate="dwithin", distance=self.r + _PAD)
        if len(idx) == 0:
            return True
        w = self.walls
        wx = w.ax[idx] - x
        wy = w.ay[idx] - y
        s = (wx * w.dx[idx] + wy * w.dy[idx]) * w.neg_inv_len2[idx]
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx + s * w.dx[idx]
        ey = wy + s * w.dy[idx]
        return math.sqrt(np.minimum.reduce(ex * ex + ey * ey)) >= limit

    def points_clearance(self, pts: np.ndarray) -> np.ndarray:
        """``Walls.clearance(pts)`` where it is below ``r`` (else some value >= ``r``)."""
        out = np.full(len(pts), np.inf)
        if len(pts) == 0:
            return out
        pi, wi = self.near_points(pts[:, 0], pts[:, 1], self.r)
        w = self.walls
        wx = pts[pi, 0] - w.ax[wi]
        wy = pts[pi, 1] - w.ay[wi]
        s = np.clip((wx * w.dx[wi] + wy * w.dy[wi]) * w.inv_len2[wi], 0.0, 1.0)
        ex = wx - s * w.dx[wi]
        ey = wy - s * w.dy[wi]
        np.minimum.at(out, pi, ex * ex + ey * ey)
        return np.sqrt(out)

    def points_clearance_closest(self, pts: np.ndarray) -> np.ndarray:
        """``Walls.point_clearance`` of each point where it is below ``r`` (else >= ``r``)."""
        out = np.full(len(pts), np.inf)
        if len(pts) == 0:
            return out
        pi, wi = self.near_points(pts[:, 0], pts[:, 1], self.r)
        w = self.walls
        wx = w.ax[wi] - pts[pi, 0]
        wy = w.ay[wi] - pts[pi, 1]
        s = (wx * w.dx[wi] + wy * w.dy[wi]) * w.neg_inv_len2[wi]
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx + s * w.dx[wi]
        ey = wy + s * w.dy[wi]
        np.minimum.at(out, pi, ex * ex + ey * ey)
        return np.sqrt(out)

    def swept_contacts(self, seg: np.ndarray, radius: float) -> np.ndarray:
        """:meth:`swept_disc_contact` of many motions ``(m, 4)`` at once: ``(m,)`` bool."""
        m = len(seg)
        if m == 0:
            return np.zeros(0, dtype=bool)
        x0, y0, x1, y1 = seg[:, 0], seg[:, 1], seg[:, 2], seg[:, 3]
        lines = shapely.linestrings(seg.reshape(-1, 2, 2))
        li, wi = self.tree.query(lines, predicate="dwithin", distance=radius + _PAD)
        w = self.walls
        ax, ay, bx, by = w.ax[wi], w.ay[wi], w.bx[wi], w.by[wi]
        dx, dy, nil = w.dx[wi], w.dy[wi], w.neg_inv_len2[wi]
        px0, py0, px1, py1 = x0[li], y0[li], x1[li], y1[li]

        def clear(x: np.ndarray, y: np.ndarray) -> np.ndarray:
            wx = ax - x
            wy = ay - y
            s = np.minimum(np.maximum((wx * dx + wy * dy) * nil, 0.0), 1.0)
            ex = wx + s * dx
            ey = wy + s * dy
            out = np.full(m, np.inf)
            np.minimum.at(out, li, ex * ex + ey * ey)
            return np.sqrt(out)

        c0, c1 = clear(px0, py0), clear(px1, py1)
        mx, my = x1 - x0, y1 - y0
        mlen2 = mx * mx + my * my
        pmx, pmy = mx[li], my[li]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = (1.0 / mlen2)[li]
            near = np.zeros(m, dtype=bool)
            for vx, vy in ((ax, ay), (bx, by)):
                wx = vx - px0
                wy = vy - py0
                s = np.minimum(np.maximum((wx * pmx + wy * pmy) * inv, 0.0), 1.0)
                ex = wx - s * pmx
                ey = wy - s * pmy
                np.logical_or.at(near, li, ex * ex + ey * ey < radius * radius)
        o1 = pmx * (ay - py0) - pmy * (ax - px0)
        o2 = pmx * (by - py0) - pmy * (bx - px0)
        o3 = dx * (py0 - ay) - dy * (px0 - ax)
        o4 = dx * (py1 - ay) - dy * (px1 - ax)
        cross = np.zeros(m, dtype=bool)
        np.logical_or.at(cross, li, (o1 * o2 < 0.0) & (o3 * o4 < 0.0))
        moved = mlen2 != 0.0
        far = ~(np.sqrt(mlen2) < c0 + c1)
        return (c0 < radius) | (c1 < radius) | (moved & (near | (far & cross)))

    def circle_clearance(self, ci: int, pts: np.ndarray) -> np.ndarray:
        """``Walls.clearance(pts)`` where it is below ``r`` (else some value >= ``r``), for
        points on vertex ``ci``'s circle."""
        idx = self.near_circle(ci)
        if len(idx) == 0:
            return np.full(len(pts), np.inf)
        w = self.walls
        wx = pts[:, 0:1] - w.ax[idx]
        wy = pts[:, 1:2] - w.ay[idx]
        s = np.clip((wx * w.dx[idx] + wy * w.dy[idx]) * w.inv_len2[idx], 0.0, 1.0)
        ex = wx - s * w.dx[idx]
        ey = wy - s * w.dy[idx]
        return np.sqrt((ex * ex + ey * ey).min(axis=1))

    def swept_disc_contact(self, x0: float, y0: float, x1: float, y1: float, radius: float) -> bool:
        """``Walls.swept_disc_contact`` for ``radius`` <= ``r``, on the walls near the motion.

        Every wall the full test can find (an end within ``radius``, a vertex within
        ``radius``, a crossing) is within ``radius`` of the motion, so it is among the candidates;
        the end clearances of the candidates bound the true ones from above only when both are
        above ``radius``, where the crossing shortcut they feed cannot drop a crossing wall
        (that wall is itself a candidate, within 0 of the motion).
        """
        line = shapely.linestrings([[x0, y0], [x1, y1]])
        idx = self.tree.query(line, predicate="dwithin", distance=radius + _PAD)
        if len(idx) == 0:
            return False
        w = self.walls
        ax, ay, bx, by = w.ax[idx], w.ay[idx], w.bx[idx], w.by[idx]
        dx, dy, nil = w.dx[idx], w.dy[idx], w.neg_inv_len2[idx]

        def clear(x: float, y: float) -> float:
            wx = ax - x
            wy = ay - y
            s = np.minimum(np.maximum((wx * dx + wy * dy) * nil, 0.0), 1.0)
            ex = wx + s * dx
            ey = wy + s * dy
            return math.sqrt(np.minimum.reduce(ex * ex + ey * ey))

        c0 = clear(x0, y0)
        if c0 < radius:
            return True
        c1 = clear(x1, y1)
        if c1 < radius:
            return True
        mx, my = x1 - x0, y1 - y0
        mlen2 = mx * mx + my * my
        if mlen2 == 0.0:
            return False
        vx = np.concatenate((ax, bx))
        vy = np.concatenate((ay, by))
        wx = vx - x0
        wy = vy - y0
        s = (wx * mx + wy * my) * (1.0 / mlen2)
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx - s * mx
        ey = wy - s * my
        if np.minimum.reduce(ex * ex + ey * ey) < radius * radius:
            return True
        if math.sqrt(mlen2) < c0 + c1:
            return False
        o1 = mx * (ay - y0) - my * (ax - x0)
        o2 = mx * (by - y0) - my * (bx - x0)
        o3 = dx * (y0 - ay) - dy * (x0 - ax)
        o4 = dx * (y1 - ay) - dy * (x1 - ax)
        return bool(np.any((o1 * o2 < 0.0) & (o3 * o4 < 0.0)))

    # --- the cone test ------------------------------------------------------------------------

    def _cone_directions(self) -> np.ndarray:
        """(vertices, k, 2): unit directions from each vertex along its walls of at least
        ``_SHORT`` m (rows of zeros pad to the largest k)."""
        w = self.walls
        verts = w.vertices
        index = {(float(x), float(y)): i for i, (x, y) in enumerate(verts)}
        dirs: list[list[tuple[float, float]]] = [[] for _ in range(len(verts))]
        for (ax, ay, bx, by), length2 in zip(
            w.segments.tolist(), (1.0 / w.inv_len2).tolist(), strict=True
        ):
            length = math.sqrt(length2)
            if length < _SHORT:
                continue
            ux, uy = (bx - ax) / length, (by - ay) / length
            dirs[index[(ax, ay)]].append((ux, uy))
            dirs[index[(bx, by)]].append((-ux, -uy))
        k = max(1, max(len(d) for d in dirs))
        out = np.zeros((len(verts), k, 2))
        for i, d in enumerate(dirs):
            if d:
                out[i, : len(d)] = d
        return out

    def cone_ok(self, ci: np.ndarray, angle: np.ndarray) -> np.ndarray:
        """False where the point at ``angle`` on vertex ``ci``'s circle is surely closer than
        ``r - 1e-7`` to one of that vertex's own walls.

        Let ``phi`` be the angle between the point's direction ``u`` and a wall of length ``L``
        leaving the vertex, with ``cos(phi) > sin(0.01)``. If the foot of the point falls on the
        wall its distance is ``r sin(phi) < r cos(0.01) < r - 5e-5 r``; else it is the far end's,
        ``sqrt(r^2 - L (2 r cos(phi) - L)) < r - L sin(0.01) / 2``. Both are below ``r - 1e-7``
        for ``r >= 0.01`` and ``L >= 1e-4``; the test is skipped for smaller clearances.
        """
        angle = np.asarray(angle, dtype=float)
        return self.cone_ok_cs(ci, np.cos(angle), np.sin(angle))

    def cone_ok_cs(self, ci: np.ndarray, ca: np.ndarray, sa: np.ndarray) -> np.ndarray:
        """:meth:`cone_ok` of the points whose direction from the vertex is ``(ca, sa)``: the
        cosine and sine of the angle, however computed (a difference of an ulp moves only
        points at the cone's edge, and those are closer than ``r - 1e-7`` to the wall either
        way, so every check answers the same)."""
        ci = np.asarray(ci)
        shape = np.broadcast(ci, ca).shape
        if self._cones is None:
            return np.ones(shape, dtype=bool)
        d = self._cones[ci]  # (..., k, 2)
        ok = d[..., 0, 0] * ca + d[..., 0, 1] * sa <= CONE_LIMIT
        for k in range(1, d.shape[-2]):  # one wall direction at a time: no (..., k) temporaries
            ok &= d[..., k, 0] * ca + d[..., k, 1] * sa <= CONE_LIMIT
        return np.broadcast_to(ok, shape).copy()

    def cone_lists(self) -> list[list[tuple[float, float]]]:
        """The cone test's wall directions per vertex as lists (empty: no test)."""
        if self._cones is None:
            return [[] for _ in range(len(self.walls.vertices))]
        return [[(ux, uy) for ux, uy in rows if ux or uy] for rows in self._cones.tolist()]
