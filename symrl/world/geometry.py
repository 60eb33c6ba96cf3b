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
    """A fixed set of wall segments with precomputed arrays for fast geometric queries.

    Arrays are laid out ``(segments, rays)`` so reductions run over the leading axis, and the
    per-step entry point :meth:`scan` shares the per-segment work between sonar, IR and clearance.
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
        self._neg_inv_len2 = -self.inv_len2
        # column views for the (segments, rays) layout
        self._ax_c, self._ay_c = self.ax[:, None], self.ay[:, None]
        self._dx_c, self._dy_c = self.dx[:, None], self.dy[:, None]
        ends = np.concatenate([seg[:, :2], seg[:, 2:]], axis=0)
        self.vertices = np.unique(ends, axis=0)  # (m, 2) distinct segment end points
        self.vx, self.vy = self.vertices[:, 0].copy(), self.vertices[:, 1].copy()

    def __len__(self) -> int:
        return self.segments.shape[0]

    # --- rays ------------------------------------------------------------------------------

    def cast(self, x: float, y: float, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distance from ``(x, y)`` along each angle ``(R,)`` to the first wall (<= max_range).

        Solves ``p + t*u = a + s*d`` for every (segment, ray) pair at once; a hit needs
        ``t > 0`` and ``0 <= s <= 1`` (with a 1e-9 tolerance so no ray slips through a vertex
        shared by two walls). Parallel pairs give inf/nan and fail the test.
        """
        return self._cast(self.ax - x, self.ay - y, np.cos(angles), np.sin(angles), max_range)

    def _cast(
        self, wx: np.ndarray, wy: np.ndarray, ux: np.ndarray, uy: np.ndarray, max_range: float
    ) -> np.ndarray:
        dx, dy = self._dx_c, self._dy_c
        wxc, wyc = wx[:, None], wy[:, None]
        denom = dy * ux - dx * uy  # (n, R): u x d
        tnum = wxc * dy - wyc * dx  # (n, 1): w x d
        snum = wxc * uy - wyc * ux  # (n, R): w x u
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv = 1.0 / denom
            t = tnum * inv
            s = snum * inv
        hit = (t > _T_EPS) & (s >= -_S_EPS) & (s <= 1.0 + _S_EPS)
        return np.minimum.reduce(t, axis=0, where=hit, initial=max_range)

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

    def point_clearance(self, x: float, y: float) -> float:
        """Distance from one point to the nearest wall (fast scalar path)."""
        _, _, ex, ey = self._closest(x, y)
        return math.sqrt(np.minimum.reduce(ex * ex + ey * ey))

    def sector_distances(
        self,
        x: float,
        y: float,
        heading: float,
        n: int,
        max_range: float,
    ) -> np.ndarray:
        """Per sector k (axis ``heading + 2*pi*k/n``, half-width ``pi/n``): distance from the
        centre to the nearest wall point whose bearing lies in the sector, capped at max_range.

        The distance along a segment is convex, so its minimum over the part of the segment
        inside a sector is at one of: the segment's closest point (the perpendicular foot), a
        segment end point, or a crossing with one of the sector's two boundary rays. Only the
        first crossing along a boundary ray can be the minimum, so the crossings reduce to a ray
        cast along the n sector edges. The 24 sectors tile the ring, so the minimum over sectors
        is the exact clearance.
        """
        width = _TWO_PI / n
        edges = heading + width * (np.arange(n + 1) - 0.5)
        wx, wy, ex, ey = self._closest(x, y)
        edge_d = self._cast(wx, wy, np.cos(edges), np.sin(edges), max_range)
        return self._sectors(x, y, ex, ey, heading, n, edge_d, max_range)

    def _closest(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``w = a - p`` and ``e = closest point of each segment - p``, all ``(n,)``."""
        wx = self.ax - x
        wy = self.ay - y
        s = (wx * self.dx + wy * self.dy) * self._neg_inv_len2
        s = np.minimum(np.maximum(s, 0.0), 1.0)
        return wx, wy, wx + s * self.dx, wy + s * self.dy

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
        best = np.minimum(edge_d[:-1], edge_d[1:])
        best = np.append(best, max_range)
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
    ) -> tuple[np.ndarray, np.ndarray | None, float]:
        """Everything a robot senses at one pose, sharing the per-segment work.

        Returns ``(rays, sectors, clearance)``: ray distances along ``heading + ray_offsets``
        (capped at ray_range), sector distances as :meth:`sector_distances` (capped at
        sector_range; ``None`` when the clearance is at least sector_range, i.e. every sector
        reads the cap), and the exact clearance of the point.
        """
        wx, wy, ex, ey = self._closest(x, y)
        clear = math.sqrt(np.minimum.reduce(ex * ex + ey * ey))
        if clear >= sector_range:
            ang = heading + ray_offsets
            return self._cast(wx, wy, np.cos(ang), np.sin(ang), ray_range), None, clear
        width = _TWO_PI / n_sectors
        edges = (heading - 0.5 * width) + width * np.arange(n_sectors + 1)
        ang = np.concatenate((heading + ray_offsets, edges))
        t = self._cast(wx, wy, np.cos(ang), np.sin(ang), ray_range)
        nr = len(ray_offsets)
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
        c0 = self.point_clearance(x0, y0) if clear0 is None else clear0
        if c0 < radius:
            return True
        c1 = self.point_clearance(x1, y1) if clear1 is None else clear1
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
