"""The planner's free-space checks: is a point, segment or arc ``r`` clear of every wall.

One :class:`PathChecker` per map and clearance (:func:`path_checker`) answers the checks of the
tangent visibility graph (:mod:`symrl.knowledge.tangent_graph`), many at once where it can, and
remembers its answers: the plans of one map from different starts share most of them.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable

import numpy as np
import shapely

from symrl.knowledge.tangents import bitangent_angles, on_circle, tangent_angles
from symrl.knowledge.wall_index import CONE_LIMIT as _CONE_LIMIT
from symrl.knowledge.wall_index import WallIndex
from symrl.world import WorldMap
from symrl.world.geometry import Walls

__all__ = ["PathChecker", "path_checker", "target_circles", "prefetch_start_and_goal"]

_EPS = 1e-9
_ARC_CHECK = 0.005  # metres between the points used to check an arc against the walls


class PathChecker:
    """Is a point / segment / arc at least ``r`` from every wall and inside the free area?

    Inside-ness is asked of shapely's prepared free-area polygon (``WorldMap.contains_xy``, in
    C): the pure-Python point-in-polygon took 84% of a plan. A point kept ``r`` from every wall
    is never on one, so the open polygon gives the same answers as the even-odd rule.

    The answers of the scalar queries are remembered (:func:`path_checker` keeps one checker per map
    and clearance): the plans of one map from different starts share their circle-to-circle
    tangents, goal tangents, arcs and rim points, and a sub-goal table asks for eight plans
    (measured on the paper's world: 5,048 point checks of which 778 differ; the table's build
    105 -> 45 ms).
    """

    def __init__(
        self, world: WorldMap, r: float, near_vertex: dict[int, list[np.ndarray]] | None = None
    ) -> None:
        """``near_vertex``: the walls near each corner, shared by the checkers of one map."""
        self.world = world
        self.walls = Walls(world.segments)
        self.r = r
        self.index = WallIndex(self.walls, r, near_vertex)
        self._cones = self.index.cone_lists()
        self._free = world.free_polygon
        shapely.prepare(self._free)
        self.points_cache: dict[tuple[float, float, float], bool] = {}
        self._segments: dict[tuple[float, ...], bool] = {}
        self._arcs: dict[tuple[float, ...], bool] = {}
        self._rims: dict[tuple[float, float, float], list[np.ndarray]] = {}
        self.nodes_cache: dict[tuple[int, float], tuple[np.ndarray, object] | None] = {}
        self._tangents: dict[tuple[float, float, int], list[float]] = {}
        self._pairs: list[tuple[int, int, list[tuple[float, float]]]] | None = None
        self._circle_bitangents: dict[int, tuple[np.ndarray, ...]] = {}

    def circle_bitangents(
        self, ci: int, make: Callable[[int], tuple[np.ndarray, ...]]
    ) -> tuple[np.ndarray, ...]:
        """``make(ci)``, the free bitangents of vertex ``ci``'s circle, remembered: they do not
        depend on the start, and a route re-plans from every position the robot reaches."""
        out = self._circle_bitangents.get(ci)
        if out is None:
            out = self._circle_bitangents[ci] = make(ci)
        return out

    def tangent_node(self, ci: int, a: float) -> tuple[np.ndarray, object] | None:
        """The point at angle ``a`` on vertex ``ci``'s circle and its graph key, or None if it
        is not free; remembered (a re-plan from a new start meets the same circle-to-circle
        tangent points: their positions and checks were two thirds of a plan)."""
        if (ci, a) in self.nodes_cache:
            return self.nodes_cache[(ci, a)]
        p = on_circle(self.walls.vertices[ci], self.r, a)
        ok = self.cone_ok(ci, a) and self.point_ok(p, tol=1e-7)
        entry = (p, ("C", ci, round(math.remainder(a, 2 * math.pi), 12))) if ok else None
        self.nodes_cache[(ci, a)] = entry
        return entry

    def point_tangents(self, p: np.ndarray, ci: int) -> list[float]:
        """:func:`tangent_angles` from ``p`` to vertex ``ci``'s circle, remembered."""
        key = (float(p[0]), float(p[1]), ci)
        angles = self._tangents.get(key)
        if angles is None:
            angles = self._tangents[key] = tangent_angles(p, self.walls.vertices[ci], self.r)
        return angles

    def bitangent_pairs(self) -> list[tuple[int, int, list[tuple[float, float]]]]:
        """:func:`bitangent_angles` of every pair of vertex circles (not depending on the start)."""
        if self._pairs is None:
            self._pairs = _bitangent_candidates(self)
        return self._pairs

    def cone_ok(self, ci: int, a: float) -> bool:
        """:meth:`WallIndex.cone_ok` of one point (no numpy: asked for every tangent)."""
        dirs = self._cones[ci]
        if not dirs:
            return True
        ca, sa = math.cos(a), math.sin(a)
        return all(ux * ca + uy * sa <= _CONE_LIMIT for ux, uy in dirs)

    def prefetch_nodes(self, requests: list[tuple[int, float]]) -> None:
        """Answer :meth:`tangent_node` for many ``(vertex, angle)`` at once (one STRtree query)."""
        todo = []
        for ci, a in dict.fromkeys(requests):
            if (ci, a) in self.nodes_cache:
                continue
            if not self.cone_ok(ci, a):
                self.nodes_cache[(ci, a)] = None
                continue
            todo.append((ci, a, on_circle(self.walls.vertices[ci], self.r, a)))
        if not todo:
            return
        pts = np.array([p for _, _, p in todo])
        ok = self.world.contains_xy(pts[:, 0], pts[:, 1]) & (
            self.index.points_clearance_closest(pts) >= self.r - 1e-7
        )
        for (ci, a, p), free in zip(todo, ok.tolist(), strict=True):
            self.points_cache[(float(p[0]), float(p[1]), 1e-7)] = free
            key = ("C", ci, round(math.remainder(a, 2 * math.pi), 12))
            self.nodes_cache[(ci, a)] = (p, key) if free else None

    def prefetch_points(self, pts: list[np.ndarray], tol: float) -> None:
        """Answer :meth:`point_ok` for many points at once."""
        keys = [(float(p[0]), float(p[1]), tol) for p in pts]
        todo = [k for k in dict.fromkeys(keys) if k not in self.points_cache]
        if not todo:
            return
        xy = np.array([k[:2] for k in todo])
        ok = self.world.contains_xy(xy[:, 0], xy[:, 1]) & (
            self.index.points_clearance_closest(xy) >= self.r - tol
        )
        self.points_cache.update(zip(todo, ok.tolist(), strict=True))

    def prefetch_segments(
        self, ends: list[tuple[np.ndarray, np.ndarray]], tol: float = 1e-7
    ) -> None:
        """Answer :meth:`segment_ok` for many segments at once."""
        keys = [(float(a[0]), float(a[1]), float(b[0]), float(b[1]), tol) for a, b in ends]
        todo = [k for k in dict.fromkeys(keys) if k not in self._segments]
        if not todo:
            return
        seg = np.array([k[:4] for k in todo])
        # a segment not inside the free area's interior touches a wall: screened out first
        # (GEOS's prepared polygon, much cheaper than the distances of a long segment)
        ok = shapely.contains_properly(self._free, shapely.linestrings(seg.reshape(-1, 2, 2)))
        rest = np.flatnonzero(ok)
        mid = 0.5 * (seg[rest, :2] + seg[rest, 2:])
        ok[rest] = self.world.contains_xy(mid[:, 0], mid[:, 1]) & ~self.index.swept_contacts(
            seg[rest], self.r - tol
        )
        self._segments.update(zip(todo, ok.tolist(), strict=True))

    def segments_free(
        self, a: np.ndarray, b: np.ndarray, tol: float = 1e-7, around: int | None = None
    ) -> np.ndarray:
        """:meth:`segment_ok` of the segments ``a[k] -> b[k]`` (``(m, 2)`` each), not remembered:
        the lazy search asks each circle's bitangents once. With ``around`` (the vertex the
        segments leave from) those crossing one of the vertex's near walls are refused first,
        in numpy: most of a corner's long bitangents hit its own room's walls, and GEOS's
        containment test of a long line was a third of a large floor's plan."""
        seg = np.concatenate([a, b], axis=1)
        ok = np.zeros(len(seg), dtype=bool)
        if len(seg) == 0:
            return ok
        live = np.arange(len(seg))
        for ring in self.index.near_vertex(around) if around is not None else []:
            live = live[~self.index.crossings(seg[live], ring)]
        if len(live) == 0:
            return ok
        ok[live] = shapely.contains_properly(
            self._free, shapely.linestrings(seg[live].reshape(-1, 2, 2))
        )
        rest = np.flatnonzero(ok)
        mid = 0.5 * (seg[rest, :2] + seg[rest, 2:])
        ok[rest] = self.world.contains_xy(mid[:, 0], mid[:, 1]) & ~self.index.swept_contacts(
            seg[rest], self.r - tol
        )
        return ok

    def points_ok(self, pts: np.ndarray, tol: float = _EPS) -> np.ndarray:
        """:meth:`point_ok` of many points ``(n, 2)`` at once."""
        inside = self.world.contains_xy(pts[:, 0], pts[:, 1])
        return inside & (self.index.points_clearance(pts) >= self.r - tol)

    def point_ok(self, p: np.ndarray, tol: float = _EPS) -> bool:
        x, y = float(p[0]), float(p[1])
        key = (x, y, tol)
        ok = self.points_cache.get(key)
        if ok is None:
            # the scalar query: the same clearance bit for bit as Walls.clearance (negated
            # differences, exact), without its array overhead (the planner asks hundreds of times)
            ok = bool(self.world.contains_xy(x, y)) and self.index.point_clearance_ge(
                x, y, self.r - tol
            )
            self.points_cache[key] = ok
        return ok

    def segment_ok(
        self,
        a: np.ndarray,
        b: np.ndarray,
        tol: float = 1e-7,
        near: list[np.ndarray] | None = None,
    ) -> bool:
        """Is the motion ``a -> b`` ``r - tol`` clear of every wall (remembered)? ``near``: rings
        of walls (:meth:`WallIndex.near_rings`) whose crossing refuses it first, in numpy (the
        start's for its long tangents: the full test of a long line was a tenth of a plan)."""
        key = (float(a[0]), float(a[1]), float(b[0]), float(b[1]), tol)
        ok = self._segments.get(key)
        if ok is None and near is not None:
            seg = np.array([key[:4]])
            if any(self.index.crossings(seg, ring)[0] for ring in near):
                ok = self._segments[key] = False
        if ok is None:
            mid = 0.5 * (a + b)
            ok = bool(self.world.contains_xy(mid[0], mid[1])) and not (
                self.index.swept_disc_contact(
                    float(a[0]), float(a[1]), float(b[0]), float(b[1]), self.r - tol
                )
            )
            self._segments[key] = ok
        return ok

    def arcs_ok(self, ci: int, spans: list[tuple[float, float]], tol: float = 1e-7) -> list[bool]:
        """Is each arc ``(a0, a1)`` of vertex ``ci``'s circle free? Points ~5 mm apart checked,
        all arcs of the circle at once (remembered)."""
        c = self.walls.vertices[ci]
        keys = [(float(c[0]), float(c[1]), a0, a1, tol) for a0, a1 in spans]
        todo = [k for k in dict.fromkeys(keys) if k not in self._arcs]
        if todo:
            angs = [
                np.linspace(
                    k[2], k[3], max(2, int(math.ceil(self.r * abs(k[3] - k[2]) / _ARC_CHECK)) + 1)
                )
                for k in todo
            ]
            ang = np.concatenate(angs)
            pts = c + self.r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
            ok = self.world.contains_xy(pts[:, 0], pts[:, 1]) & (
                self.index.circle_clearance(ci, pts) >= self.r - tol
            )
            starts = np.cumsum([0] + [len(a) for a in angs[:-1]])
            for k, all_ok in zip(todo, np.logical_and.reduceat(ok, starts).tolist(), strict=True):
                self._arcs[k] = bool(all_ok)
        return [self._arcs[k] for k in keys]

    def rim_targets(self, g: np.ndarray, rg: float) -> list[np.ndarray]:
        """:func:`_rim_targets` of the goal disc (g, rg), remembered (copies: the caller's)."""
        key = (float(g[0]), float(g[1]), rg)
        if key not in self._rims:
            self._rims[key] = _rim_targets(self, g, rg)
        return [p.copy() for p in self._rims[key]]


def _bitangent_candidates(chk: PathChecker) -> list[tuple[int, int, list[tuple[float, float]]]]:
    """:func:`bitangent_angles` of every pair of vertex circles, less the tangents whose two ends
    both fail the cone test (their nodes would both be refused): the pairs are screened with
    numpy, row by row, and only the survivors are computed exactly (the same floats as before)."""
    c = chk.walls.vertices
    r = chk.r
    index = chk.index
    out = []
    for i in range(len(c) - 1):
        j = np.arange(i + 1, len(c))
        v = c[j] - c[i]
        d = np.hypot(v[:, 0], v[:, 1])
        base = np.arctan2(v[:, 1], v[:, 0])
        inner = d > 2 * r
        off = np.arccos(np.minimum(1.0, 2 * r / np.maximum(d, 1e-300)))
        half = math.pi / 2
        on_i = np.stack([base + half, base - half, base + off, base - off], axis=1)
        on_j = np.stack(
            [base + half, base - half, base + off + math.pi, base - off + math.pi], axis=1
        )
        keep = index.cone_ok(np.full(on_i.shape, i), on_i) | index.cone_ok(j[:, None], on_j)
        keep[:, 2:] &= inner[:, None]
        keep &= (d >= 1e-12)[:, None]
        for row in np.flatnonzero(keep.any(axis=1)).tolist():
            jj = i + 1 + row
            pairs = bitangent_angles(c[i], c[jj], r)
            mask = keep[row].tolist()
            if len(pairs) == 2 + 2 * bool(inner[row]):
                pairs = [p for p, k in zip(pairs, mask, strict=False) if k]
            out.append((i, jj, pairs))
    chk.prefetch_nodes(
        [(i, a1) for i, _, pairs in out for a1, _ in pairs]
        + [(j, a2) for _, j, pairs in out for _, a2 in pairs]
    )
    ends = []
    for k, m, pairs in out:
        for a1, a2 in pairs:
            n1, n2 = chk.nodes_cache[(k, a1)], chk.nodes_cache[(m, a2)]
            if n1 is not None and n2 is not None:
                ends.append((n1[0], n2[0]))
    chk.prefetch_segments(ends)
    return out


def target_circles(chk: PathChecker, q: np.ndarray, first: int) -> np.ndarray:
    """Circles from ``first`` on that the target ``q`` may lie on or have a free tangent point on
    (the others would refuse every tangent node: :meth:`PathChecker.cone_ok`)."""
    c = chk.walls.vertices[first:]
    v = q - c
    d = np.hypot(v[:, 0], v[:, 1])
    on = np.abs(d - chk.r) < 1e-6 + 1e-9
    base = np.arctan2(v[:, 1], v[:, 0])
    off = np.arccos(np.minimum(1.0, chk.r / np.maximum(d, 1e-300)))
    idx = np.arange(first, len(chk.walls.vertices))
    cone = chk.index.cone_ok(idx, base + off) | chk.index.cone_ok(idx, base - off)
    return idx[on | (cone & (d >= chk.r - 1e-12 - 1e-9))]


def prefetch_start_and_goal(chk: PathChecker, s: np.ndarray, g: np.ndarray, rg: float) -> None:
    """Ask the checks of the start's and the goal centre's tangents in batches."""
    centres = chk.walls.vertices
    s_req = [(ci, a) for ci, c in enumerate(centres) for a in tangent_angles(s, c, chk.r)]
    g_req = [(ci, a) for ci in range(len(centres)) for a in chk.point_tangents(g, ci)]
    chk.prefetch_nodes(s_req + g_req)
    nodes = chk.nodes_cache
    ends = [(s, n[0]) for q in s_req if (n := nodes[q]) is not None]
    legs = []
    for q in g_req:
        if (n := nodes[q]) is not None:
            p = n[0]
            d = float(np.hypot(*(g - p)))
            if d > rg:
                legs.append((p, g + (p - g) * (rg / d)))
    chk.prefetch_points([q for _, q in legs], 1e-7)
    ends += [(p, q) for p, q in legs if chk.points_cache[(float(q[0]), float(q[1]), 1e-7)]]
    chk.prefetch_segments(ends)


_CHECKERS: dict[int, tuple[weakref.ref, dict[float, PathChecker], dict]] = {}
"""The checkers of the maps planned on in this process, by the map object's id (a WorldMap is
frozen; the weak reference tells a reused id from the same map), and the walls near each corner,
which the checkers of one map share (``symrl plan`` plans at two clearances)."""


def path_checker(world: WorldMap, r: float) -> PathChecker:
    """The checker of ``world`` at clearance ``r``, with what it was asked before."""
    entry = _CHECKERS.get(id(world))
    if entry is None or entry[0]() is not world:
        if len(_CHECKERS) >= 16:
            _CHECKERS.clear()
        entry = _CHECKERS[id(world)] = (weakref.ref(world), {}, {})
    chk = entry[1].get(r)
    if chk is None:
        chk = entry[1][r] = PathChecker(world, r, entry[2])
    return chk


def _rim_targets(
    chk: PathChecker, g: np.ndarray, rg: float, samples: int = 3600
) -> list[np.ndarray]:
    """Points of the goal rim where it enters or leaves the grown walls (bisection on the angle)."""
    ang = np.linspace(0.0, 2 * math.pi, samples, endpoint=False)
    rim = g + rg * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    ok = chk.points_ok(rim).tolist()
    out = []
    for i in range(samples):
        j = (i + 1) % samples
        if ok[i] == ok[j]:
            continue
        lo, hi = ang[i], ang[i] + 2 * math.pi / samples  # lo has ok[i], hi has ok[j]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if chk.point_ok(g + rg * np.array([math.cos(mid), math.sin(mid)])) == ok[i]:
                lo = mid
            else:
                hi = mid
        good = lo if ok[i] else hi
        out.append(g + rg * np.array([math.cos(good), math.sin(good)]))
    return out
