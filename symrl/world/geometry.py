"""Vectorised wall geometry: ray casting, clearance, IR sectors and the swept-disc contact test.

Every wall is a segment ``(x0, y0, x1, y1)``. :class:`Walls` precomputes the per-segment arrays
once, so the per-step queries are a handful of numpy operations over ``(segments, rays)`` with no
Python loop over rays or segments (the env calls them hundreds of thousands of times). The
module-level functions are convenience wrappers that build a ``Walls`` per call; hot loops should
build one ``Walls`` and call its methods. The precomputation and the queries at one point are
its base class's (:class:`symrl.world.wall_queries.WallQueries`); this module adds the batched
ones.

The ``*_many`` methods answer the same queries for B points or poses at once (arrays with a leading
B axis), for :class:`symrl.world.physics.RobotBatch`. Row b of their result is bitwise equal to the
scalar method at pose b, whatever B is: they use the same floating-point operations in the same
order, element-wise, and the ray cast does one small matrix product per row (``np.matmul`` over a
stack), the same BLAS call as the scalar :meth:`Walls.cast`, so no result depends on the batch.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from symrl.world.wall_queries import S_EPS, TWO_PI, WallQueries, ray_directions

__all__ = [
    "Walls",
    "clearance",
    "inverse_hits",
    "nearest_hits",
    "ray_cast",
    "sector_distances",
    "swept_disc_contact",
]


class Walls(WallQueries):
    """A fixed set of wall segments with precomputed arrays for fast geometric queries: those of
    :class:`~symrl.world.wall_queries.WallQueries` at one point, and the same for B points or
    poses at once (``*_many``). Not thread-safe (scratch buffers per instance); use one
    ``Walls`` per env.
    """

    def __init__(self, segments: np.ndarray) -> None:
        super().__init__(segments)
        self._kept: dict[tuple[Any, ...], Any] = {}  # see _keep

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
        b, r = angles.shape
        return nearest_hits(hits, self._flat_rows(b, r), max_range)

    def _inverse_hits(
        self, x: np.ndarray, y: np.ndarray, angles: np.ndarray, u: np.ndarray | None = None
    ) -> np.ndarray:
        """``(B, n, R)``: :func:`inverse_hits` of these walls (``u``: the rays' directions
        ``(2, B, R)``, cosines then sines, if known)."""
        b, _ = angles.shape
        if u is None:
            u = ray_directions(angles)
        return inverse_hits(
            self.normals, self.a_perp, self.a_cross_d, self._cast_buffers(b), x, y, u
        )

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
        n = self.n_walls
        return self._keep(("rows", b, r), lambda: n * r * np.arange(b)[:, None] + np.arange(r))

    def _cast_buffers(self, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Scratch arrays of :meth:`cast_many` for B = b (overwritten by every call)."""

        def make() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            k = np.empty((b, 3 * self.n_walls, 2))
            k[:, : self.n_walls] = self.normals
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
        width = TWO_PI / n
        b = len(x)
        cx = np.concatenate((ex, self.vx - x[:, None]), axis=1)
        cy = np.concatenate((ey, self.vy - y[:, None]), axis=1)
        rel = np.arctan2(cy, cx) - (heading - 0.5 * width)[:, None]
        idx = (np.mod(rel, TWO_PI) * (1.0 / width)).astype(np.intp)
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
            ("edges", n_sectors), lambda: (TWO_PI / n_sectors) * np.arange(n_sectors + 1)
        )
        nr = len(ray_offsets)
        angles = np.empty((len(heading), nr + n_sectors + 1))
        np.add(heading[:, None], ray_offsets, out=angles[:, :nr])
        first = heading - 0.5 * (TWO_PI / n_sectors)
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


def inverse_hits(
    normals: np.ndarray,
    a_perp: np.ndarray,
    a_cross_d: np.ndarray,
    buffers: tuple[np.ndarray, np.ndarray, np.ndarray],
    x: np.ndarray,
    y: np.ndarray,
    u: np.ndarray,
) -> np.ndarray:
    """``(B, n, R)``: 1 / distance along each ray from ``(x[b], y[b])`` in directions ``u``
    ``(2, B, R)`` (cosines, then sines) to each of n walls it hits, -inf for a miss. The walls
    are :class:`~symrl.world.wall_queries.WallQueries`' per-wall terms, one set for every row
    (``normals`` (n, 2), ``a_perp`` (n, 2), ``a_cross_d`` (n,)) or one per row (``(B, n, 2)``,
    ``(B, n)``); ``buffers``: scratch ``k`` (B, 3n, 2) with the normals in its first n rows,
    ``xy`` (B, 2, 1) and ``yx`` (B, 1, 2), overwritten.

    The directions are kept as two contiguous ``(B, R)`` blocks (a caller's element-wise work
    on a strided block costs twice as much); the product reads them as each row's ``(2, R)``
    matrix with a leading dimension of ``B * R``, the same BLAS call."""
    k, xy, yx = buffers
    n = normals.shape[-2]
    xy[:, 0, 0] = x
    xy[:, 1, 0] = y
    yx[:, 0, 0] = y
    np.negative(x, out=yx[:, 0, 1])
    np.add(a_perp, yx, out=k[:, n : 2 * n])  # one add of (y, -x), not one per column
    tnum = a_cross_d - np.matmul(normals, xy)[:, :, 0]  # w x d, one (n,2)@(2,) per row
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv_tnum = 1.0 / tnum
        inv_tnum[tnum == 0.0] = 0.0
        np.multiply(normals, inv_tnum[:, :, None], out=k[:, 2 * n :])
        prod = np.matmul(k, u.transpose(1, 0, 2))  # (B, 3n, R)
        s = prod[:, n : 2 * n] / prod[:, :n]
    ok = (s >= -S_EPS) & (s <= 1.0 + S_EPS)
    return np.where(ok, prod[:, 2 * n :], -np.inf)


def nearest_hits(
    hits: np.ndarray, rows: np.ndarray, max_range: float
) -> tuple[np.ndarray, np.ndarray]:
    """The ranges ``(B, R)`` (at most ``max_range``) and the wall each ray hits ``(B, R)`` (-1
    for none within range) from :func:`inverse_hits`' ``hits`` ``(B, n, R)``; ``rows``
    ``(B, R)``: each ray's wall 0 in the flat ``hits`` (``n * R * b + ray``)."""
    wall = np.argmax(hits, axis=1)
    # the value at the argmax, gathered from the flat array: the maximum (a NaN included, as
    # argmax picks the first NaN), for 3 small calls instead of a reduction over the walls
    # (measured: 4.3 -> 1.9 us at B = 10, 24 rays)
    inv_t = hits.reshape(-1).take(wall * hits.shape[2] + rows)
    floor = 1.0 / max_range
    # fmax(inv_t, floor) is where(~(inv_t > floor), floor, inv_t), a NaN included
    return 1.0 / np.fmax(inv_t, floor), np.where(inv_t > floor, wall, -1)
