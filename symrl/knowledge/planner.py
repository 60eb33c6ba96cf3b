"""The optimum a learner is held against: the shortest collision-free path to the goal disc.

Method: an exact **tangent visibility graph** for a disc robot among polygonal walls. Keeping a
clearance ``R`` (body radius + IR collision distance = 0.26 + 0.056 m by default) from every wall
is the same as moving a point among the walls grown by ``R``; every shortest path of that point is
made of straight segments tangent to circles of radius ``R`` around wall vertices and arcs of those
circles. The graph's nodes are the start, the tangent points (start-to-circle, circle-to-circle,
goal-to-circle) and the target points; every edge is checked against the walls, and Dijkstra
(networkx) picks the shortest.

The target is the goal disc (the trial ends when the centre is within ``goal.radius``). A shortest
path first touches that disc either on an open arc of its rim, where its last leg points at the
goal centre (a tangent from the goal centre, cut at the rim), or at a rim point where the rim meets
the grown walls (found by bisection on the rim angle to ~1e-12 rad). Both are in the graph, so the
length is exact up to the arc sampling used only to *check* arcs against other walls (5 mm; an
arc that grazes another wall between samples by less than a few micrometres would be missed).

The planner is knowledge: an agent told the map's full geometry plans its sub-goals with it
(``learner/options.py``), and the studies divide every result by its length (``symrl plan``,
the "x optimum"), with the same code.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field

import networkx as nx
import numpy as np
import shapely

from symrl.knowledge.wall_index import CONE_LIMIT as _CONE_LIMIT
from symrl.knowledge.wall_index import WallIndex
from symrl.world import WorldMap
from symrl.world.geometry import Walls

__all__ = ["Plan", "shortest_path", "robot_clearances"]

_EPS = 1e-9
_ARC_CHECK = 0.005  # metres between the points used to check an arc against the walls


@dataclass
class Plan:
    """A shortest path: its length, the actions it needs, and its geometry for plots."""

    length: float
    """Length of the path in metres (start centre to the first point inside the goal disc)."""
    actions: int
    """``ceil(length / step)``: fewest actions of ``step`` metres that can cover the path."""
    clearance: float
    """Distance kept from every wall (robot centre to wall), metres."""
    step: float
    points: np.ndarray
    """Dense polyline of the path (k, 2), points at most 5 mm apart along arcs."""
    waypoints: list[tuple[float, float]] = field(default_factory=list)
    """The graph nodes the path goes through (tangent points and the end point)."""
    method: str = "tangent visibility graph (exact segments and arcs) + Dijkstra"
    error_bound: float = 1e-6

    def to_dict(self) -> dict:
        """JSON-ready summary (no dense polyline)."""
        return {
            "length_m": self.length,
            "actions": self.actions,
            "clearance_m": self.clearance,
            "step_m": self.step,
            "waypoints": [list(map(float, w)) for w in self.waypoints],
            "method": self.method,
            "length_error_bound_m": self.error_bound,
        }


def robot_clearances() -> tuple[float, float, float]:
    """(body radius, IR collision distance, step) of the default robot, read from RobotConfig."""
    from symrl.world.robot import RobotConfig

    cfg = RobotConfig()
    return cfg.radius, cfg.ir_collision_distance, cfg.step


# --- geometry helpers --------------------------------------------------------------------------


def _point_tangents(p: np.ndarray, c: np.ndarray, r: float) -> list[float]:
    """Angles (around c) of the tangent points from point p to the circle (c, r)."""
    d = float(np.hypot(*(p - c)))
    if d < r - 1e-12:
        return []
    base = math.atan2(p[1] - c[1], p[0] - c[0])
    off = math.acos(min(1.0, r / d))
    return [base + off, base - off] if off > 1e-12 else [base]


def _bitangents(c1: np.ndarray, c2: np.ndarray, r: float) -> list[tuple[float, float]]:
    """Pairs of angles (on circle 1, on circle 2) of the tangent segments of two equal circles."""
    v = c2 - c1
    d = float(np.hypot(*v))
    if d < 1e-12:
        return []
    base = math.atan2(v[1], v[0])
    pairs = [(base + math.pi / 2, base + math.pi / 2), (base - math.pi / 2, base - math.pi / 2)]
    if d > 2 * r:  # inner (crossing) tangents through the midpoint
        off = math.acos(2 * r / d)
        pairs += [(base + off, base + off + math.pi), (base - off, base - off + math.pi)]
    return pairs


def _on_circle(c: np.ndarray, r: float, a: float) -> np.ndarray:
    return c + r * np.array([math.cos(a), math.sin(a)])


class _Checker:
    """Is a point / segment / arc at least ``r`` from every wall and inside the free area?

    Inside-ness is asked of shapely's prepared free-area polygon (``WorldMap.contains_xy``, in
    C): the pure-Python point-in-polygon took 84% of a plan. A point kept ``r`` from every wall
    is never on one, so the open polygon gives the same answers as the even-odd rule.

    The answers of the scalar queries are remembered (:func:`_checker` keeps one checker per map
    and clearance): the plans of one map from different starts share their circle-to-circle
    tangents, goal tangents, arcs and rim points, and a sub-goal table asks for eight plans
    (measured on the paper's world: 5,048 point checks of which 778 differ; the table's build
    105 -> 45 ms).
    """

    def __init__(self, world: WorldMap, r: float) -> None:
        self.world = world
        self.walls = Walls(world.segments)
        self.r = r
        self.index = WallIndex(self.walls, r)
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

    def tangent_node(self, ci: int, a: float) -> tuple[np.ndarray, object] | None:
        """The point at angle ``a`` on vertex ``ci``'s circle and its graph key, or None if it
        is not free; remembered (a re-plan from a new start meets the same circle-to-circle
        tangent points: their positions and checks were two thirds of a plan)."""
        if (ci, a) in self.nodes_cache:
            return self.nodes_cache[(ci, a)]
        p = _on_circle(self.walls.vertices[ci], self.r, a)
        ok = self.cone_ok(ci, a) and self.point_ok(p, tol=1e-7)
        entry = (p, ("C", ci, round(math.remainder(a, 2 * math.pi), 12))) if ok else None
        self.nodes_cache[(ci, a)] = entry
        return entry

    def point_tangents(self, p: np.ndarray, ci: int) -> list[float]:
        """:func:`_point_tangents` from ``p`` to vertex ``ci``'s circle, remembered."""
        key = (float(p[0]), float(p[1]), ci)
        angles = self._tangents.get(key)
        if angles is None:
            angles = self._tangents[key] = _point_tangents(p, self.walls.vertices[ci], self.r)
        return angles

    def bitangent_pairs(self) -> list[tuple[int, int, list[tuple[float, float]]]]:
        """:func:`_bitangents` of every pair of vertex circles (they do not depend on the start)."""
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
            todo.append((ci, a, _on_circle(self.walls.vertices[ci], self.r, a)))
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

    def segment_ok(self, a: np.ndarray, b: np.ndarray, tol: float = 1e-7) -> bool:
        key = (float(a[0]), float(a[1]), float(b[0]), float(b[1]), tol)
        ok = self._segments.get(key)
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


def _bitangent_candidates(chk: _Checker) -> list[tuple[int, int, list[tuple[float, float]]]]:
    """:func:`_bitangents` of every pair of vertex circles, less the tangents whose two ends both
    fail the cone test (their nodes would both be refused): the pairs are screened with numpy,
    row by row, and only the survivors are computed exactly (the same floats as before)."""
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
            pairs = _bitangents(c[i], c[jj], r)
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


def _target_circles(chk: _Checker, q: np.ndarray, first: int) -> np.ndarray:
    """Circles from ``first`` on that the target ``q`` may lie on or have a free tangent point on
    (the others would refuse every tangent node: :meth:`_Checker.cone_ok`)."""
    c = chk.walls.vertices[first:]
    v = q - c
    d = np.hypot(v[:, 0], v[:, 1])
    on = np.abs(d - chk.r) < 1e-6 + 1e-9
    base = np.arctan2(v[:, 1], v[:, 0])
    off = np.arccos(np.minimum(1.0, chk.r / np.maximum(d, 1e-300)))
    idx = np.arange(first, len(chk.walls.vertices))
    cone = chk.index.cone_ok(idx, base + off) | chk.index.cone_ok(idx, base - off)
    return idx[on | (cone & (d >= chk.r - 1e-12 - 1e-9))]


def _prefetch_start_and_goal(chk: _Checker, s: np.ndarray, g: np.ndarray, rg: float) -> None:
    """Ask the checks of the start's and the goal centre's tangents in batches."""
    centres = chk.walls.vertices
    s_req = [(ci, a) for ci, c in enumerate(centres) for a in _point_tangents(s, c, chk.r)]
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


_CHECKERS: dict[int, tuple[weakref.ref, dict[float, _Checker]]] = {}
"""The checkers of the maps planned on in this process, by the map object's id (a WorldMap is
frozen; the weak reference tells a reused id from the same map)."""


def _checker(world: WorldMap, r: float) -> _Checker:
    """The checker of ``world`` at clearance ``r``, with what it was asked before."""
    entry = _CHECKERS.get(id(world))
    if entry is None or entry[0]() is not world:
        if len(_CHECKERS) >= 16:
            _CHECKERS.clear()
        entry = _CHECKERS[id(world)] = (weakref.ref(world), {})
    chk = entry[1].get(r)
    if chk is None:
        chk = entry[1][r] = _Checker(world, r)
    return chk


def _rim_targets(chk: _Checker, g: np.ndarray, rg: float, samples: int = 3600) -> list[np.ndarray]:
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


# --- the planner -------------------------------------------------------------------------------


def shortest_path(
    world: WorldMap,
    start: tuple[float, float] | tuple[float, float, float] | None = None,
    clearance: float | None = None,
    step: float | None = None,
) -> Plan:
    """Shortest path keeping ``clearance`` from every wall, from ``start`` to the goal disc.

    ``clearance`` defaults to body radius + IR collision distance of :class:`RobotConfig`;
    ``step`` to its translation per action. Raises ``ValueError`` if the start is too close to a
    wall or no path exists.
    """
    radius, ir_dist, default_step = robot_clearances()
    r = float(radius + ir_dist if clearance is None else clearance)
    step = float(default_step if step is None else step)
    if not (r > 0 and step > 0):
        raise ValueError(f"clearance and step must be positive, got {r} and {step}")
    s = np.array((world.start.x, world.start.y) if start is None else start[:2], dtype=float)
    g = np.array((world.goal.x, world.goal.y), dtype=float)
    rg = float(world.goal.radius)
    chk = _checker(world, r)
    if not chk.point_ok(s):
        raise ValueError(f"start {tuple(s)} is closer than {r:.3f} m to a wall or outside the map")
    if np.hypot(*(s - g)) <= rg:
        return Plan(0.0, 0, r, step, s[None, :], [tuple(s)])

    centres = chk.walls.vertices
    graph = nx.Graph()
    pos: dict = {"S": s}
    arcs_on: dict[int, list[tuple[float, object]]] = {i: [] for i in range(len(centres))}
    edges_geom: dict = {}

    def add_tangent_node(ci: int, a: float) -> object | None:
        node = chk.tangent_node(ci, a)
        if node is None:
            return None
        p, key = node
        if key not in pos:
            pos[key] = p
            arcs_on[ci].append((math.remainder(a, 2 * math.pi), key))
        return key

    def add_segment(u: object, v: object) -> None:
        a, b = pos[u], pos[v]
        if u != v and chk.segment_ok(a, b):
            graph.add_edge(u, v, weight=float(np.hypot(*(b - a))))
            edges_geom[frozenset((u, v))] = ("seg",)

    targets: list[tuple[str, int]] = []
    # the circles each target may have a tangent or lie on, by circle (a target made at
    # circle ci is tried on circles ci, ci + 1, ...), with their checks asked in batches
    near_targets: dict[int, list[tuple[str, int]]] = {i: [] for i in range(len(centres))}
    current = [0]

    def new_target(q: np.ndarray) -> tuple[str, int]:
        key = ("T", len(targets))
        pos[key] = q
        targets.append(key)
        first = current[0]
        circles = _target_circles(chk, q, first)
        for ci in circles.tolist():
            near_targets[ci].append(key)
        requests = [(ci, a) for ci in circles.tolist() for a in chk.point_tangents(q, ci)]
        chk.prefetch_nodes(requests)
        nodes = (chk.nodes_cache[req] for req in requests)
        ends = [(node[0], q) for node in nodes if node is not None]
        chk.prefetch_segments(ends)
        return key

    def add_leg_to_centre(u: object) -> None:
        p = pos[u]
        d = float(np.hypot(*(g - p)))
        if d <= rg:
            return
        q = g + (p - g) * (rg / d)
        if not chk.point_ok(q, tol=1e-7):
            return
        add_segment(u, new_target(q))

    # targets: rim points where the rim meets the grown walls, and the rim cut of every leg
    # that points at the goal centre (from the start, and from tangents of the goal centre)
    for rim_point in chk.rim_targets(g, rg):
        new_target(rim_point)
    add_leg_to_centre("S")
    for t in list(targets):
        add_segment("S", t)
    _prefetch_start_and_goal(chk, s, g, rg)
    for ci, c in enumerate(centres):
        current[0] = ci
        for a in _point_tangents(s, c, r):
            k = add_tangent_node(ci, a)
            if k is not None:
                add_segment("S", k)
        for a in chk.point_tangents(g, ci):
            k = add_tangent_node(ci, a)
            if k is not None:
                add_leg_to_centre(k)
        for t in near_targets[ci]:
            tp = pos[t]
            if abs(float(np.hypot(*(tp - c))) - r) < 1e-6:  # the target lies on this circle
                a = math.atan2(tp[1] - c[1], tp[0] - c[0])
                arcs_on[ci].append((a, t))
                continue
            for a in chk.point_tangents(tp, ci):
                k = add_tangent_node(ci, a)
                if k is not None:
                    add_segment(k, t)
    for i, j, pairs in chk.bitangent_pairs():
        for a1, a2 in pairs:
            k1, k2 = add_tangent_node(i, a1), add_tangent_node(j, a2)
            if k1 is not None and k2 is not None:
                add_segment(k1, k2)
    # arcs between neighbouring nodes on each circle
    for ci, nodes in arcs_on.items():
        nodes.sort(key=lambda t: t[0])
        m = len(nodes)
        arcs = []
        for idx in range(m if m > 2 else m - 1):
            (a0, u), (a1, v) = nodes[idx], nodes[(idx + 1) % m]
            if idx == m - 1:
                a1 += 2 * math.pi
            if u == v or a1 - a0 < 1e-12:
                continue
            arcs.append((a0, a1, u, v))
        if not arcs:
            continue
        free = chk.arcs_ok(ci, [(a0, a1) for a0, a1, _, _ in arcs])
        for (a0, a1, u, v), ok in zip(arcs, free, strict=True):
            if ok:
                w = r * (a1 - a0)
                if not graph.has_edge(u, v) or graph[u][v]["weight"] > w:
                    graph.add_edge(u, v, weight=w)
                    edges_geom[frozenset((u, v))] = ("arc", ci, a0, a1)
    for t in targets:
        if t in graph:
            graph.add_edge(t, "GOAL", weight=0.0)
    if "S" not in graph or "GOAL" not in graph:
        raise ValueError("no collision-free path from the start to the goal disc")
    try:
        length, route = nx.single_source_dijkstra(graph, "S", "GOAL")
    except nx.NetworkXNoPath:
        raise ValueError("no collision-free path from the start to the goal disc") from None
    route = route[:-1]
    points = _dense(route, pos, edges_geom, centres, r)
    return Plan(
        length=float(length),
        actions=int(math.ceil(float(length) / step - 1e-9)),
        clearance=r,
        step=step,
        points=points,
        waypoints=[(float(pos[k][0]), float(pos[k][1])) for k in route],
    )


def _dense(route: list, pos: dict, geom: dict, centres: np.ndarray, r: float) -> np.ndarray:
    """The path as a polyline: segment end points and arcs sampled every ~5 mm."""
    pts = [pos[route[0]]]
    for u, v in zip(route[:-1], route[1:], strict=False):
        g = geom[frozenset((u, v))]
        if g[0] == "arc":
            _, ci, a0, a1 = g
            ang = np.linspace(a0, a1, max(2, int(math.ceil(r * (a1 - a0) / 0.005)) + 1))
            start, end = _on_circle(centres[ci], r, a0).tolist(), pos[v].tolist()
            if all(abs(x - y) <= 1e-6 + 1e-5 * abs(y) for x, y in zip(start, end, strict=True)):
                ang = ang[::-1]
            pts.extend(centres[ci] + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)[1:])
        else:
            pts.append(pos[v])
    return np.asarray(pts, dtype=float)
