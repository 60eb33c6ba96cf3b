"""Vectorised wall geometry: ray casting, clearance, IR sectors and the swept-disc contact test.

Every wall is a segment ``(x0, y0, x1, y1)``. :class:`Walls` precomputes the per-segment arrays
once, so the per-step queries are a handful of numpy operations over ``(rays, segments)`` with no
Python loop over rays or segments (the env calls them hundreds of thousands of times).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Walls", "ray_cast", "clearance", "sector_distances", "swept_disc_contact"]

_S_EPS = 1e-9  # tolerance on the segment parameter so rays never slip through a shared vertex
_T_EPS = 1e-12  # a hit must lie strictly ahead of the ray origin
_TWO_PI = 2.0 * math.pi


class Walls:
    """A fixed set of wall segments with precomputed arrays for fast geometric queries."""

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
        ends = np.concatenate([seg[:, :2], seg[:, 2:]], axis=0)
        self.vertices = np.unique(ends, axis=0)  # (m, 2) distinct segment end points
        self.vx, self.vy = self.vertices[:, 0].copy(), self.vertices[:, 1].copy()

    def __len__(self) -> int:
        return self.segments.shape[0]

    # --- rays ------------------------------------------------------------------------------

    def cast(self, x: float, y: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distance from ``(x, y)`` along each angle ``(R,)`` to the first wall, capped at max_range.

        Solves ``p + t*u = a + s*d`` for every (ray, segment) pair at once; a hit needs
        ``t > 0`` and ``0 <= s <= 1``. Parallel pairs give inf/nan and fail the test.
        """
        ux = np.cos(angles)[:, None]
        uy = np.sin(angles)[:, None]
        wx = self.ax - x
        wy = self.ay - y
        denom = ux * self.dy - uy * self.dx  # (R, n): u x d
        tnum = wx * self.dy - wy * self.dx  # (n,): w x d
        snum = wx * uy - wy * ux  # (R, n): w x u
        with np.errstate(divide="ignore", invalid="ignore"):
            t = tnum / denom
            s = snum / denom
        hit = (t > _T_EPS) & (s >= -_S_EPS) & (s <= 1.0 + _S_EPS)
        return np.where(hit, t, max_range).min(axis=1)

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

    def sector_distances(
        self,
        x: float,
        y: float,
        heading: float,
        n: int,
        max_range: float,
        edge_distances: np.ndarray | None = None,
    ) -> np.ndarray:
        """Per sector k (axis ``heading + 2*pi*k/n``, half-width ``pi/n``): distance from the
        centre to the nearest wall point whose bearing lies in the sector, capped at max_range.

        The distance along a segment is convex, so its minimum over the part of the segment inside
        a sector is at one of: the perpendicular foot, a segment end point, or a crossing with one
        of the sector's two boundary rays. The boundary crossings reduce to a ray cast along the n
        sector edges (only the first hit can be the minimum); pass ``edge_distances`` (edge k at
        ``heading + 2*pi*(k - 0.5)/n``) if it was already cast together with other rays.
        """
        width = _TWO_PI / n
        if edge_distances is None:
            edges = heading + width * (np.arange(n) - 0.5)
            edge_distances = self.cast(x, y, edges, max_range)
        best = np.minimum(edge_distances, np.roll(edge_distances, -1))
        # perpendicular feet (only where the foot lies on the segment) and segment end points
        wx = x - self.ax
        wy = y - self.ay
        s = (wx * self.dx + wy * self.dy) * self.inv_len2
        fx = s * self.dx - wx  # foot minus centre
        fy = s * self.dy - wy
        foot_d = np.sqrt(fx * fx + fy * fy)
        foot_d[(s < 0.0) | (s > 1.0)] = np.inf
        vx = self.vx - x
        vy = self.vy - y
        cx = np.concatenate((fx, vx))
        cy = np.concatenate((fy, vy))
        cd = np.concatenate((foot_d, np.sqrt(vx * vx + vy * vy)))
        rel = np.mod(np.arctan2(cy, cx) - heading + 0.5 * width, _TWO_PI)
        idx = np.minimum((rel / width).astype(np.intp), n - 1)
        mask = idx[None, :] == np.arange(n)[:, None]
        best = np.minimum(best, np.where(mask, cd[None, :], np.inf).min(axis=1))
        return np.minimum(best, max_range)

    # --- motion ----------------------------------------------------------------------------

    def swept_disc_contact(
        self, x0: float, y0: float, x1: float, y1: float, radius: float
    ) -> bool:
        """True iff the disc of ``radius`` moved from ``(x0, y0)`` to ``(x1, y1)`` touches a wall:
        the distance between the motion segment and some wall segment is below ``radius``."""
        mx, my = x1 - x0, y1 - y0
        mlen2 = mx * mx + my * my
        # the motion's two end points against every wall
        d = float(self.clearance(np.array([[x0, y0], [x1, y1]])).min())
        if d < radius:
            return True
        if mlen2 == 0.0:
            return False
        # every wall end point against the motion segment
        wx = self.vx - x0
        wy = self.vy - y0
        s = np.clip((wx * mx + wy * my) / mlen2, 0.0, 1.0)
        ex = wx - s * mx
        ey = wy - s * my
        if float((ex * ex + ey * ey).min()) < radius * radius:
            return True
        # a proper crossing of the motion segment with a wall
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
    return _walls(walls).cast(
        float(origin[0]), float(origin[1]), np.asarray(angles, dtype=np.float64), max_range
    )


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
