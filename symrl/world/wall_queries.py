"""Wall segments and the geometric queries at one point or pose: ray cast, clearance, IR sectors
and the swept-disc contact test.

:class:`WallQueries` precomputes the per-segment arrays once, so each query is a handful of numpy
operations over ``(segments, rays)`` with no Python loop over rays or segments. Its subclass
:class:`symrl.world.geometry.Walls` adds the same queries for B poses at once.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["WallQueries", "ray_directions"]

S_EPS = 1e-9
"""Tolerance on the segment parameter so rays never slip through a shared vertex."""
TWO_PI = 2.0 * math.pi


class WallQueries:
    """A fixed set of wall segments with precomputed arrays, and the queries at one point.

    The per-step queries are written to keep the number of numpy calls small (at this size the
    call overhead, not the arithmetic, is the cost): rays are cast with one ``(3n, 2) @ (2, R)``
    matrix product, and :meth:`scan` shares the per-segment work between sonar, IR and clearance.
    Not thread-safe (one scratch buffer per instance).
    """

    def __init__(self, segments: np.ndarray) -> None:
        seg = np.ascontiguousarray(segments, dtype=np.float64).reshape(-1, 4)
        if seg.shape[0] == 0:
            raise ValueError("Walls: need at least one wall segment, got none")
        if not np.all(np.isfinite(seg)):
            raise ValueError("Walls: segment coordinates must be finite")
        self.segments = seg
        self.ax, self.ay = seg[:, 0].copy(), seg[:, 1].copy()
        self.bx, self.by = seg[:, 2].copy(), seg[:, 3].copy()
        self.dx, self.dy = self.bx - self.ax, self.by - self.ay
        len2 = self.dx**2 + self.dy**2
        if np.any(len2 <= 0.0):
            bad = int(np.argmax(len2 <= 0.0))
            raise ValueError(f"Walls: segment {bad} {seg[bad].tolist()} has zero length")
        self.inv_len2 = 1.0 / len2
        self.neg_inv_len2 = -self.inv_len2
        n = seg.shape[0]
        self.n_walls = n
        # ray casting: for a ray p + t*u and a wall a + s*d, with w = a - p and x the 2-D cross
        # product, t = (w x d) / (u x d) and s = (w x u) / (u x d). Every term is a dot product
        # with u, so one matrix product gives them all: rows (dy, -dx) -> u x d,
        # rows (-wy, wx) -> w x u, rows (dy, -dx) / (w x d) -> (u x d) / (w x d) = 1 / t.
        self.normals = np.stack([self.dy, -self.dx], axis=1)  # (n, 2)
        self.a_perp = np.stack([-self.ay, self.ax], axis=1)  # (-wy, wx) = this + (y, -x)
        self.a_cross_d = self.ax * self.dy - self.ay * self.dx  # a x d; w x d = a x d - p x d
        self._k = np.empty((3 * n, 2))
        self._k[:n] = self.normals
        ends = np.concatenate([seg[:, :2], seg[:, 2:]], axis=0)
        self.vertices = np.unique(ends, axis=0)  # (m, 2) distinct segment end points
        self.vx, self.vy = self.vertices[:, 0].copy(), self.vertices[:, 1].copy()

    def __len__(self) -> int:
        return self.n_walls

    # --- rays ------------------------------------------------------------------------------

    def cast(self, x: float, y: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distance from ``(x, y)`` along each angle ``(R,)`` to the first wall (<= max_range).

        A hit needs ``t > 0`` and ``0 <= s <= 1`` (a 1e-9 tolerance on s, so no ray slips
        through a vertex shared by two walls); parallel pairs give inf/nan and fail the test.
        The nearest hit is the largest ``1/t``, so the ``t > 0`` test is free: a reduction that
        starts at ``1/max_range`` never picks a hit behind the origin.
        """
        n = self.n_walls
        k = self._k
        u = ray_directions(angles)
        np.add(self.a_perp, (y, -x), out=k[n : 2 * n])
        tnum = self.a_cross_d - self.normals @ (
            x,
            y,
        )  # w x d; 0 when p is on the wall's line: no hit
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv_tnum = 1.0 / tnum
            inv_tnum[tnum == 0.0] = 0.0
            np.multiply(self.normals, inv_tnum[:, None], out=k[2 * n :])
            prod = k @ u  # (3n, R)
            s = prod[n : 2 * n] / prod[:n]
        ok = (s >= -S_EPS) & (s <= 1.0 + S_EPS)
        # fmax skips the nan of a wall whose line passes (within 1e-308) through the origin
        inv_t = np.fmax.reduce(prod[2 * n :], axis=0, where=ok, initial=1.0 / max_range)
        return 1.0 / inv_t

    # --- distances -------------------------------------------------------------------------

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Distance from each point ``(..., 2)`` to the nearest wall, shape ``(...)``."""
        pts = np.asarray(points, dtype=np.float64)
        shape = pts.shape[:-1]
        flat = pts.reshape(-1, 2)
        wx = flat[:, 0:1] - self.ax
        wy = flat[:, 1:2] - self.ay
        s = np.clip((wx * self.dx + wy * self.dy) * self.inv_len2, 0.0, 1.0)
        ex = wx - s * self.dx
        ey = wy - s * self.dy
        return np.sqrt((ex * ex + ey * ey).min(axis=1)).reshape(shape)

    def closest(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Each segment's closest point relative to ``(x, y)`` (ex, ey, shape ``(n,)``) and the
        point's clearance; pass the result to :meth:`scan` to reuse it."""
        wx = self.ax - x
        wy = self.ay - y
        s = (wx * self.dx + wy * self.dy) * self.neg_inv_len2
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx + s * self.dx
        ey = wy + s * self.dy
        return ex, ey, math.sqrt(np.minimum.reduce(ex * ex + ey * ey))

    def point_clearance(self, x: float, y: float) -> float:
        """Distance from one point to the nearest wall (fast scalar path)."""
        return self.closest(x, y)[2]

    def sector_distances(
        self, x: float, y: float, heading: float, n: int, max_range: float
    ) -> np.ndarray:
        """Per sector k (axis ``heading + 2*pi*k/n``, half-width ``pi/n``): distance from the
        centre to the nearest wall point whose bearing lies in the sector, capped at max_range.

        The distance along a segment is convex, so its minimum over the part of the segment
        inside a sector is at one of: the segment's closest point (the perpendicular foot), a
        segment end point, or a crossing with one of the sector's two boundary rays. Only the
        first crossing along a boundary ray can be the minimum, so the crossings reduce to a ray
        cast along the n sector edges. The sectors tile the ring, so the minimum over sectors
        is the exact clearance.
        """
        width = TWO_PI / n
        edge_d = self.cast(x, y, heading + width * (np.arange(n + 1) - 0.5), max_range)
        ex, ey, _ = self.closest(x, y)
        return self._sectors(x, y, ex, ey, heading, n, edge_d, max_range)

    def _sectors(
        self,
        x: float,
        y: float,
        ex: np.ndarray,
        ey: np.ndarray,
        heading: float,
        n: int,
        edge_d: np.ndarray,
        max_range: float,
    ) -> np.ndarray:
        """Sector minima from the closest points ``e`` (relative to the centre), the vertices and
        the n+1 edge ray distances (edge n repeats edge 0)."""
        width = TWO_PI / n
        cx = np.concatenate((ex, self.vx - x))
        cy = np.concatenate((ey, self.vy - y))
        rel = np.arctan2(cy, cx) - (heading - 0.5 * width)
        idx = (np.mod(rel, TWO_PI) * (1.0 / width)).astype(np.intp)
        best = np.empty(n + 1)
        np.minimum(edge_d[:-1], edge_d[1:], out=best[:n])
        best[n] = max_range
        np.minimum.at(best, idx, np.hypot(cx, cy))  # idx == n only on the edge of sector 0
        if best[n] < best[0]:
            best[0] = best[n]
        return best[:n]

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
        """Everything a robot senses at one pose, sharing the per-segment work.

        Returns ``(rays, sectors, clearance)``: ray distances along ``heading + ray_offsets``
        (capped at ray_range), sector distances as :meth:`sector_distances` (capped at
        sector_range; ``None`` when the clearance is at least sector_range, i.e. every sector
        reads the cap), and the exact clearance of the point. ``closest`` is
        :meth:`closest` at the same point, if already computed.
        """
        ex, ey, clear = self.closest(x, y) if closest is None else closest
        if clear >= sector_range:
            return self.cast(x, y, heading + ray_offsets, ray_range), None, clear
        width = TWO_PI / n_sectors
        nr = len(ray_offsets)
        edges = (heading - 0.5 * width) + width * np.arange(n_sectors + 1)
        t = self.cast(x, y, np.concatenate((heading + ray_offsets, edges)), ray_range)
        edge_d = np.minimum(t[nr:], sector_range)
        sectors = self._sectors(x, y, ex, ey, heading, n_sectors, edge_d, sector_range)
        return t[:nr], sectors, clear

    # --- motion ----------------------------------------------------------------------------

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
        """True iff the disc of ``radius`` moved from ``(x0, y0)`` to ``(x1, y1)`` touches a wall:
        the distance between the motion segment and some wall segment is below ``radius``.

        Two non-crossing segments are closest at an end point of one of them, so the test is:
        an end of the motion near a wall, a wall vertex near the motion, or a proper crossing.
        ``clear0``/``clear1`` are the end points' clearances if already known.
        """
        c0 = self.closest(x0, y0)[2] if clear0 is None else clear0
        if c0 < radius:
            return True
        c1 = self.closest(x1, y1)[2] if clear1 is None else clear1
        if c1 < radius:
            return True
        mx, my = x1 - x0, y1 - y0
        mlen2 = mx * mx + my * my
        if mlen2 == 0.0:
            return False
        wx = self.vx - x0
        wy = self.vy - y0
        s = (wx * mx + wy * my) * (1.0 / mlen2)
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx - s * mx
        ey = wy - s * my
        if np.minimum.reduce(ex * ex + ey * ey) < radius * radius:
            return True
        if math.sqrt(mlen2) < c0 + c1:
            return False  # a crossing point would be >= c0 from one end and >= c1 from the other
        o1 = mx * (self.ay - y0) - my * (self.ax - x0)
        o2 = mx * (self.by - y0) - my * (self.bx - x0)
        o3 = self.dx * (y0 - self.ay) - self.dy * (x0 - self.ax)
        o4 = self.dx * (y1 - self.ay) - self.dy * (x1 - self.ax)
        return bool(np.any((o1 * o2 < 0.0) & (o3 * o4 < 0.0)))


def ray_directions(angles: np.ndarray) -> np.ndarray:
    """``(2, *angles.shape)``: the rays' cosines, then sines, each a contiguous block."""
    u = np.empty((2, *np.shape(angles)))
    np.cos(angles, out=u[0])
    np.sin(angles, out=u[1])
    return u
