"""B sets of wall segments, one per row of a batched query: each row's rays cast against its
own set only, all rows in the same few numpy calls.

The scan odometry matches each robot's scan against walls of its own (the echoes of its last
keyframe): one :class:`~symrl.world.geometry.Walls` per robot would cast one robot at a time,
a Python loop over the batch whose numpy calls, not their arithmetic, are the cost. Here the
sets are padded to one count with walls no ray reaches and stacked, and cast by the functions
of :meth:`Walls.cast_many_walls <symrl.world.geometry.Walls.cast_many_walls>`
(:func:`~symrl.world.geometry.inverse_hits`, :func:`~symrl.world.geometry.nearest_hits`) with
per-row wall terms: row b's ranges and walls are bitwise those of ``Walls(sets[b])`` at the
same pose, whatever the other rows hold (for sets of two walls or more: a one-wall ``Walls``
takes numpy's dot path for its (1, 2) @ (2, 1) product, which rounds differently in the last
bit).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from symrl.world.geometry import inverse_hits, nearest_hits
from symrl.world.wall_queries import ray_directions

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
            raise ValueError(
                f"WallSets: row {bad // n}'s segment {bad % n} {seg[bad].tolist()} has zero length"
            )
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
        b, r = angles.shape
        if b != self.batch:
            raise ValueError(f"WallSets.cast_many_walls: {b} rows of rays for {self.batch} sets")
        u = directions
        if u is None:
            u = ray_directions(angles)
        buffers = (self._k, self._xy, self._yx)
        hits = inverse_hits(self.normals, self.a_perp, self.a_cross_d, buffers, x, y, u)
        rows = self._rows.get(r)
        if rows is None:
            rows = self._rows[r] = self.n_walls * r * np.arange(b)[:, None] + np.arange(r)
        ranges, wall = nearest_hits(hits, rows, max_range)
        return ranges, np.where(wall >= 0, wall + self._first, -1)
