"""Vectorised wall geometry: ray casting, clearance, IR sectors and the swept-disc contact test.

Every wall is a segment ``(x0, y0, x1, y1)``. :class:`Walls` precomputes the per-segment arrays
once, so the per-step queries are a handful of numpy operations over ``(segments, rays)`` with no
Python loop over rays or segments (the env calls them hundreds of thousands of times). The
module-level functions are convenience wrappers that build a ``Walls`` per call; hot loops should
build one ``Walls`` and call its methods.

The ``*_many`` methods answer the same queries for B points or poses at once (arrays with a leading
B axis), for :class:`symrl.world.physics.RobotBatch`. Row b of their result is bitwise equal to the
scalar method at pose b, whatever B is: they use the same floating-point operations in the same
order, element-wise, and the ray cast does one small matrix product per row (``np.matmul`` over a
stack), the same BLAS call as the scalar :meth:`Walls.cast`, so no result depends on the batch.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["Walls", "ray_cast", "clearance", "sector_distances", "swept_disc_contact"]

_S_EPS = 1e-9  # tolerance on the segment parameter so rays never slip through a shared vertex
_TWO_PI = 2.0 * math.pi


class Walls:
    """A fixed set of wall segments with precomputed arrays for fast geometric queries.

    The per-step queries are written to keep the number of numpy calls small (at this size the
    call overhead, not the arithmetic, is the cost): rays are cast with one ``(3n, 2) @ (2, R)``
    matrix product, and :meth:`scan` shares the per-segment work between sonar, IR and clearance.
    Not thread-safe (one scratch buffer per instance); use one ``Walls`` per env.
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
        self._n = n
        # ray casting: for a ray p + t*u and a wall a + s*d, with w = a - p and x the 2-D cross
        # product, t = (w x d) / (u x d) and s = (w x u) / (u x d). Every term is a dot product
        # with u, so one matrix product gives them all: rows (dy, -dx) -> u x d,
        # rows (-wy, wx) -> w x u, rows (dy, -dx) / (w x d) -> (u x d) / (w x d) = 1 / t.
        self._nd = np.stack([self.dy, -self.dx], axis=1)  # (n, 2)
        self._aj = np.stack([-self.ay, self.ax], axis=1)  # (-wy, wx) = this + (y, -x)
        self._axd = self.ax * self.dy - self.ay * self.dx  # a x d; w x d = a x d - p x d
        self._k = np.empty((3 * n, 2))
        self._k[:n] = self._nd
        self._kept: dict[tuple[Any, ...], Any] = {}  # see _keep
        ends = np.concatenate([seg[:, :2], seg[:, 2:]], axis=0)
        self.vertices = np.unique(ends, axis=0)  # (m, 2) distinct segment end points
        self.vx, self.vy = self.vertices[:, 0].copy(), self.vertices[:, 1].copy()

    def __len__(self) -> int:
        return self._n

    # --- rays ------------------------------------------------------------------------------

    def cast(self, x: float, y: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distance from ``(x, y)`` along each angle ``(R,)`` to the first wall (<= max_range).

        A hit needs ``t > 0`` and ``0 <= s <= 1`` (a 1e-9 tolerance on s, so no ray slips
        through a vertex shared by two walls); parallel pairs give inf/nan and fail the test.
        The nearest hit is the largest ``1/t``, so the ``t > 0`` test is free: a reduction that
        starts at ``1/max_range`` never picks a hit behind the origin.
        """
        n = self._n
        k = self._k
        u = np.empty((2, len(angles)))
        np.cos(angles, out=u[0])
        np.sin(angles, out=u[1])
        np.add(self._aj, (y, -x), out=k[n : 2 * n])
        tnum = self._axd - self._nd @ (x, y)  # w x d; 0 when p is on the wall's line: no hit
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv_tnum = 1.0 / tnum
            inv_tnum[tnum == 0.0] = 0.0
            np.multiply(self._nd, inv_tnum[:, None], out=k[2 * n :])
            prod = k @ u  # (3n, R)
            s = prod[n : 2 * n] / prod[:n]
        ok = (s >= -_S_EPS) & (s <= 1.0 + _S_EPS)
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
        width = _TWO_PI / n
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
        width = _TWO_PI / n
        cx = np.concatenate((ex, self.vx - x))
        cy = np.concatenate((ey, self.vy - y))
        rel = np.arctan2(cy, cx) - (heading - 0.5 * width)
        idx = (np.mod(rel, _TWO_PI) * (1.0 / width)).astype(np.intp)
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
        width = _TWO_PI / n_sectors
        nr = len(ray_offsets)
        edges = (heading - 0.5 * width) + width * np.arange(n_sectors + 1)
        t = self.cast(x, y, np.concatenate((heading + ray_offsets, edges)), ray_range)
        edge_d = np.minimum(t[nr:], sector_range)
        sectors = self._sectors(x, y, ex, ey, heading, n_sectors, edge_d, sector_range)
        return t[:nr], sectors, clear

    # --- the same queries for B poses at once ----------------------------------------------

    def closest_many(
        self, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`closest` for B points: ex, ey ``(B, n)`` and the clearances ``(B,)``."""
        if len(x) == 1:  # the scalar method (same numbers) has less overhead
            ex1, ey1, c = self.closest(float(x[0]), float(y[0]))
            return ex1[None], ey1[None], np.array([c])
        wx = self.ax - x[:, None]
        wy = self.ay - y[:, None]
        s = (wx * self.dx + wy * self.dy) * self.neg_inv_len2
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        ex = wx + s * self.dx
        ey = wy + s * self.dy
        return ex, ey, np.sqrt(np.minimum.reduce(ex * ex + ey * ey, axis=1))

    def cast_many(
        self, x: np.ndarray, y: np.ndarray, angles: np.ndarray, max_range: float
    ) -> np.ndarray:
        """:meth:`cast` for B origins, each with its own R angles ``(B, R)``: ``(B, R)``.

        One ``(3n, 2) @ (2, R)`` product per row through a stacked ``np.matmul`` (the BLAS
        call of :meth:`cast`; a single ``(B, 2) @ (2, n)`` product would round differently)."""
        # the misses are -inf, so an unmasked reduction gives the same maximum (fmax picks a
        # value, it does not round; -inf never beats the positive initial) at a fraction of the
        # cost of a reduction with where= (a masked inner loop, measured 3-5x slower here)
        inv_t = np.fmax.reduce(self._inverse_hits(x, y, angles), axis=1, initial=1.0 / max_range)
        return 1.0 / inv_t

    def cast_many_walls(
        self,
        x: np.ndarray,
        y: np.ndarray,
        angles: np.ndarray,
        max_range: float,
        directions: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`cast_many` and the wall each ray hits ``(B, R)`` (index into ``segments``,
        -1 for a ray that reaches ``max_range``): what a pose's derivative of a range needs.
        ``directions``: ``(2, B, R)``, the cosines and sines of ``angles`` if the caller has
        them (the localiser needs them too; computing them once saves two calls)."""
        hits = self._inverse_hits(x, y, angles, directions)
        wall = np.argmax(hits, axis=1)
        # the value at the argmax, gathered from the flat array: the maximum (a NaN included,
        # as argmax picks the first NaN), for 3 small calls instead of a reduction over the
        # walls (measured: 4.3 -> 1.9 us at B = 10, 24 rays)
        b, r = angles.shape
        inv_t = hits.reshape(-1).take(wall * r + self._flat_rows(b, r))
        floor = 1.0 / max_range
        # fmax(inv_t, floor) is where(~(inv_t > floor), floor, inv_t), a NaN included
        return 1.0 / np.fmax(inv_t, floor), np.where(inv_t > floor, wall, -1)

    def _inverse_hits(
        self, x: np.ndarray, y: np.ndarray, angles: np.ndarray, u: np.ndarray | None = None
    ) -> np.ndarray:
        """``(B, n, R)``: 1 / distance along each ray to each wall it hits, -inf for a miss
        (``u``: the rays' directions ``(2, B, R)``, cosines then sines, if known).

        The directions are kept as two contiguous ``(B, R)`` blocks (a caller's element-wise
        work on a strided block costs twice as much); the product reads them as each row's
        ``(2, R)`` matrix with a leading dimension of ``B * R``, the same BLAS call."""
        n = self._n
        b, r = angles.shape
        k, xy, yx = self._cast_buffers(b)
        if u is None:
            u = np.empty((2, b, r))
            np.cos(angles, out=u[0])
            np.sin(angles, out=u[1])
        xy[:, 0, 0] = x
        xy[:, 1, 0] = y
        yx[:, 0, 0] = y
        np.negative(x, out=yx[:, 0, 1])
        np.add(self._aj, yx, out=k[:, n : 2 * n])  # one add of (y, -x), not one per column
        tnum = self._axd - np.matmul(self._nd, xy)[:, :, 0]  # w x d, one (n,2)@(2,) per row
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv_tnum = 1.0 / tnum
            inv_tnum[tnum == 0.0] = 0.0
            np.multiply(self._nd, inv_tnum[:, :, None], out=k[:, 2 * n :])
            prod = np.matmul(k, u.transpose(1, 0, 2))  # (B, 3n, R)
            s = prod[:, n : 2 * n] / prod[:, :n]
        ok = (s >= -_S_EPS) & (s <= 1.0 + _S_EPS)
        return np.where(ok, prod[:, 2 * n :], -np.inf)

    def _keep(self, key: tuple[Any, ...], make: Callable[[], Any]) -> Any:
        """``make()``, made once per ``key`` and kept for the next calls: the index arrays and
        scratch buffers of the batched queries, whose few shapes recur every step (making them
        is a noticeable part of a step at these sizes)."""
        value = self._kept.get(key)
        if value is None:
            if len(self._kept) >= 32:  # a handful of shapes per run; forget old ones
                self._kept.clear()
            value = self._kept[key] = make()
        return value

    def _flat_rows(self, b: int, r: int) -> np.ndarray:
        """``(b, r)``: the flat index of wall 0 for each ray in a ``(b, n, r)`` array."""
        n = self._n
        return self._keep(("rows", b, r), lambda: n * r * np.arange(b)[:, None] + np.arange(r))

    def _cast_buffers(self, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Scratch arrays of :meth:`cast_many` for B = b (overwritten by every call)."""

        def make() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            k = np.empty((b, 3 * self._n, 2))
            k[:, : self._n] = self._nd
            return k, np.empty((b, 2, 1)), np.empty((b, 1, 2))

        return self._keep(("cast", b), make)

    def _sectors_many(
        self,
        x: np.ndarray,
        y: np.ndarray,
        ex: np.ndarray,
        ey: np.ndarray,
        heading: np.ndarray,
        n: int,
        edge_d: np.ndarray,
        max_range: float,
    ) -> np.ndarray:
        """:meth:`_sectors` for B poses (``edge_d`` ``(B, n + 1)``): ``(B, n)``."""
        width = _TWO_PI / n
        b = len(x)
        cx = np.concatenate((ex, self.vx - x[:, None]), axis=1)
        cy = np.concatenate((ey, self.vy - y[:, None]), axis=1)
        rel = np.arctan2(cy, cx) - (heading - 0.5 * width)[:, None]
        idx = (np.mod(rel, _TWO_PI) * (1.0 / width)).astype(np.intp)
        idx += self._row_bins(b, n)  # row b's bins in the flat buffer
        best = np.empty((b, n + 1))
        np.minimum(edge_d[:, :-1], edge_d[:, 1:], out=best[:, :n])
        best[:, n] = max_range
        np.minimum.at(best.reshape(-1), idx.reshape(-1), np.hypot(cx, cy).reshape(-1))
        np.minimum(best[:, 0], best[:, n], out=best[:, 0])
        return best[:, :n]

    def _row_bins(self, b: int, n: int) -> np.ndarray:
        """``(b, 1)``: the first of row i's n + 1 bins in :meth:`_sectors_many`'s flat buffer."""
        return self._keep(("bins", b, n), lambda: (n + 1) * np.arange(b)[:, None])

    def _scan_angles(
        self, heading: np.ndarray, ray_offsets: np.ndarray, n_sectors: int
    ) -> np.ndarray:
        """``(B, R + n_sectors + 1)``: the ray angles ``heading + ray_offsets``, then the sector
        edges ``(heading - width / 2) + width * k``, written into one new array (no
        concatenation; the edges' ``width * k`` kept per sector count)."""
        steps = self._keep(
            ("edges", n_sectors), lambda: (_TWO_PI / n_sectors) * np.arange(n_sectors + 1)
        )
        nr = len(ray_offsets)
        angles = np.empty((len(heading), nr + n_sectors + 1))
        np.add(heading[:, None], ray_offsets, out=angles[:, :nr])
        first = heading - 0.5 * (_TWO_PI / n_sectors)
        np.add(first[:, None], steps, out=angles[:, nr:])
        return angles

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
        """:meth:`scan` for B poses: rays ``(B, R)``, sectors ``(B, n_sectors)`` and the
        clearances ``(B,)``. Rows with a clearance of at least ``sector_range`` (where
        :meth:`scan` returns ``None``) read ``sector_range`` in every sector; ``sectors`` is
        ``None`` when that holds for every row. ``closest``: :meth:`closest_many` at the points."""
        if len(x) == 1:  # the scalar method (same numbers) has less overhead
            one = None if closest is None else (closest[0][0], closest[1][0], float(closest[2][0]))
            rays, sec, c = self.scan(
                float(x[0]),
                float(y[0]),
                float(heading[0]),
                ray_offsets,
                n_sectors,
                ray_range,
                sector_range,
                one,
            )
            return rays[None], None if sec is None else sec[None], np.array([c])
        ex, ey, clear = self.closest_many(x, y) if closest is None else closest
        far = ~(clear < sector_range)
        if far.all():
            return self.cast_many(x, y, heading[:, None] + ray_offsets, ray_range), None, clear
        nr = len(ray_offsets)
        t = self.cast_many(x, y, self._scan_angles(heading, ray_offsets, n_sectors), ray_range)
        edge_d = np.minimum(t[:, nr:], sector_range)
        # every row at once, then the far rows blanked: each row is computed on its own (the
        # same numbers as for a subset of the rows), and the extra rows cost about what
        # gathering the subset did (about half of the robots are near a wall at B = 10)
        sectors = self._sectors_many(x, y, ex, ey, heading, n_sectors, edge_d, sector_range)
        if far.any():
            sectors[far] = sector_range
        return t[:, :nr], sectors, clear

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
        """:meth:`swept_disc_contact` for B motions with known end clearances: ``(B,)`` bool."""
        if len(x0) == 1:  # the scalar method (same answer) has less overhead
            hit = self.swept_disc_contact(
                float(x0[0]),
                float(y0[0]),
                float(x1[0]),
                float(y1[0]),
                radius,
                float(clear0[0]),
                float(clear1[0]),
            )
            return np.array([hit])
        mx, my = x1 - x0, y1 - y0
        mlen2 = mx * mx + my * my
        with np.errstate(divide="ignore", invalid="ignore"):
            wx = self.vx - x0[:, None]
            wy = self.vy - y0[:, None]
            s = (wx * mx[:, None] + wy * my[:, None]) * (1.0 / mlen2)[:, None]
            s = np.minimum(np.maximum(s, 0.0), 1.0)
            ex = wx - s * mx[:, None]
            ey = wy - s * my[:, None]
            vertex = np.minimum.reduce(ex * ex + ey * ey, axis=1) < radius * radius
        far_apart = np.sqrt(mlen2) >= clear0 + clear1  # only then can the motion cross a wall
        o1 = mx[:, None] * (self.ay - y0[:, None]) - my[:, None] * (self.ax - x0[:, None])
        o2 = mx[:, None] * (self.by - y0[:, None]) - my[:, None] * (self.bx - x0[:, None])
        o3 = self.dx * (y0[:, None] - self.ay) - self.dy * (x0[:, None] - self.ax)
        o4 = self.dx * (y1[:, None] - self.ay) - self.dy * (x1[:, None] - self.ax)
        cross = np.any((o1 * o2 < 0.0) & (o3 * o4 < 0.0), axis=1)
        moved = mlen2 != 0.0
        return (clear0 < radius) | (clear1 < radius) | (moved & (vertex | (far_apart & cross)))

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


# --- functional wrappers (build the Walls once and reuse it in hot loops) ---------------------


def _walls(walls: Walls | np.ndarray) -> Walls:
    return walls if isinstance(walls, Walls) else Walls(walls)


def ray_cast(
    walls: Walls | np.ndarray, origin: tuple[float, float], angles: np.ndarray, max_range: float
) -> np.ndarray:
    """Distance from ``origin`` along each angle to the first wall, capped at ``max_range``."""
    angles = np.atleast_1d(np.asarray(angles, dtype=np.float64))
    return _walls(walls).cast(float(origin[0]), float(origin[1]), angles.ravel(), max_range)


def clearance(walls: Walls | np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point ``(..., 2)`` to the nearest wall."""
    return _walls(walls).clearance(points)


def sector_distances(
    walls: Walls | np.ndarray, pose: tuple[float, float, float], n: int, max_range: float
) -> np.ndarray:
    """Nearest wall distance from the centre within each of the ``n`` sectors around ``pose``."""
    return _walls(walls).sector_distances(
        float(pose[0]), float(pose[1]), float(pose[2]), n, max_range
    )


def swept_disc_contact(
    walls: Walls | np.ndarray,
    start: tuple[float, float],
    end: tuple[float, float],
    radius: float,
) -> bool:
    """True iff a disc of ``radius`` moving in a straight line from start to end touches a wall."""
    return _walls(walls).swept_disc_contact(
        float(start[0]), float(start[1]), float(end[0]), float(end[1]), radius
    )
