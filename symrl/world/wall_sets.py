"""B sets of wall segments, one per row of a batched query: each row's rays cast against its
own set only, all rows in the same few numpy calls.

The scan odometry matches each robot's scan against walls of its own (the echoes of its last
keyframe): one :class:`~symrl.world.geometry.Walls` per robot would cast one robot at a time,
a Python loop over the batch whose numpy calls, not their arithmetic, are the cost. Here the
sets are padded to one count with walls no ray reaches and stacked, so the cast is the batched
one of :meth:`Walls.cast_many_walls <symrl.world.geometry.Walls.cast_many_walls>`, written
with the same floating-point operations per row: row b's ranges and walls are bitwise those of
``Walls(sets[b])`` at the same pose, whatever the other rows hold (for sets of two walls or
more: a one-wall ``Walls`` takes numpy's dot path for its (1, 2) @ (2, 1) product, which
rounds differently in the last bit).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from symrl.world.wall_queries import S_EPS

__all__ = ["WallSets"]

FAR = 1.0e6
"""Where the padding walls lie (m): out of every ray's reach."""


class WallSets:
    """Row b's wall segments ``sets[b]`` (k_b, 4) for a batch of B rows.

    The walls are numbered across the rows, row b's from ``b * n_walls`` (``n_walls`` the
    largest set's count; a smaller set is padded), so the per-wall arrays ``ax``, ``ay``,
    ``dx``, ``dy`` and ``inv_len2`` (B * n_walls,) are read by the wall index a cast returns,
    as a :class:`~symrl.world.geometry.Walls`' are.
    """

    def __init__(self, sets: Sequence[np.ndarray]) -> None:
        if len(sets) == 0:
            raise ValueError("WallSets: need at least one row's walls, got none")
        rows = [np.asarray(s, dtype=np.float64).reshape(-1, 4) for s in sets]
        n = max(len(s) for s in rows)
        if n == 0:
            raise ValueError("WallSets: need at least one wall segment, got none")
        pad = np.array([FAR, FAR, FAR + 1.0, FAR])
        seg = np.concatenate([np.concatenate((s, np.tile(pad, (n - len(s), 1)))) for s in rows])
        if not np.all(np.isfinite(seg)):
            raise ValueError("WallSets: segment coordinates must be finite")
        self.segments = seg
        self.n_walls = n
        self.batch = len(rows)
        self.ax, self.ay = seg[:, 0].copy(), seg[:, 1].copy()
        self.dx, self.dy = seg[:, 2] - self.ax, seg[:, 3] - self.ay
        len2 = self.dx**2 + self.dy**2
        if np.any(len2 <= 0.0):
            bad = int(np.argmax(len2 <= 0.0))
            raise ValueError(f"WallSets: segment {bad} {seg[bad].tolist()} has zero length")
        self.inv_len2 = 1.0 / len2
        # as Walls', per row (B, n, ...): see WallQueries for the terms of the product
        shape = (self.batch, n)
        self.normals = np.stack([self.dy, -self.dx], axis=1).reshape(*shape, 2)
        self.a_perp = np.stack([-self.ay, self.ax], axis=1).reshape(*shape, 2)
        self.a_cross_d = (self.ax * self.dy - self.ay * self.dx).reshape(shape)
        self._first = (n * np.arange(self.batch))[:, None]  # row b's first wall
        # scratch for the casts (the same few shapes every call): the product's matrix, its
        # first block the normals, and the origins as columns and as rows
        self._k = np.empty((self.batch, 3 * n, 2))
        self._k[:, :n] = self.normals
        self._xy = np.empty((self.batch, 2, 1))
        self._yx = np.empty((self.batch, 1, 2))
        self._rows: dict[int, np.ndarray] = {}  # per ray count: each ray's wall 0 in the flat hits

    def __len__(self) -> int:
        return self.batch

    def cast_many_walls(
        self,
        x: np.ndarray,
        y: np.ndarray,
        angles: np.ndarray,
        max_range: float,
        directions: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Row b's rays from ``(x[b], y[b])`` at ``angles[b]`` (B, R) against row b's walls: the
        ranges (B, R), at most ``max_range``, and the wall each ray hits (B, R) (an index into
        the per-wall arrays; -1 for a ray that reaches ``max_range``). ``directions``: the
        rays' cosines and sines (2, B, R), if the caller has them."""
        n = self.n_walls
        b, r = angles.shape
        if b != self.batch:
            raise ValueError(f"WallSets.cast_many_walls: {b} rows of rays for {self.batch} sets")
        u = directions
        if u is None:
            u = np.empty((2, b, r))
            np.cos(angles, out=u[0])
            np.sin(angles, out=u[1])
        k, xy, yx = self._k, self._xy, self._yx
        xy[:, 0, 0], xy[:, 1, 0] = x, y
        yx[:, 0, 0] = y
        np.negative(x, out=yx[:, 0, 1])
        np.add(self.a_perp, yx, out=k[:, n : 2 * n])
        tnum = self.a_cross_d - np.matmul(self.normals, xy)[:, :, 0]  # w x d
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv_tnum = 1.0 / tnum
            inv_tnum[tnum == 0.0] = 0.0
            np.multiply(self.normals, inv_tnum[:, :, None], out=k[:, 2 * n :])
            prod = np.matmul(k, u.transpose(1, 0, 2))  # (B, 3n, R)
            s = prod[:, n : 2 * n] / prod[:, :n]
        ok = (s >= -S_EPS) & (s <= 1.0 + S_EPS)
        hits = np.where(ok, prod[:, 2 * n :], -np.inf)  # 1 / range, -inf for a miss
        wall = np.argmax(hits, axis=1)
        rows = self._rows.get(r)
        if rows is None:
            rows = self._rows[r] = n * r * np.arange(b)[:, None] + np.arange(r)
        inv_t = hits.reshape(-1).take(wall * r + rows)  # the maximum, gathered
        floor = 1.0 / max_range
        return 1.0 / np.fmax(inv_t, floor), np.where(inv_t > floor, wall + self._first, -1)
