"""The tangent visibility graph of one plan: its nodes, checked edges and shortest route.

:class:`TangentGraph` builds, for one start and goal disc, the graph that
:func:`symrl.knowledge.planner.shortest_path` searches: the start, tangent points on the circles
of radius ``r`` around the wall vertices, and target points on the goal rim, joined by the
segments and arcs that :class:`~symrl.knowledge.path_checks.PathChecker` finds free.
"""

from __future__ import annotations

import math
from bisect import bisect_left

import networkx as nx
import numpy as np

from symrl.knowledge.circle_tables import SAME_ANGLE as SAME
from symrl.knowledge.path_checks import PathChecker, prefetch_start_and_goal, target_circles
from symrl.knowledge.tangents import on_circle, tangent_angles

__all__ = ["TangentGraph"]


class TangentGraph:
    """The graph of the shortest paths from the start ``s`` into the goal disc ``(g, rg)``,
    built by :meth:`build` (the start ``"S"``, tangent nodes ``("C", vertex, angle)``, targets
    ``("T", i)`` joined to ``"GOAL"``); :meth:`shortest_route` searches it."""

    def __init__(self, chk: PathChecker, s: np.ndarray, g: np.ndarray, rg: float) -> None:
        self.chk = chk
        self.r = chk.r
        self.s, self.g, self.rg = s, g, rg
        self.centres = chk.walls.vertices
        self.graph = nx.Graph()
        self.pos: dict = {"S": s}
        n = len(self.centres)
        self.arcs_on: dict[int, list[tuple[float, object]]] = {i: [] for i in range(n)}
        # each circle's tangent nodes by angle (sorted), and the keys of tangent points that
        # are one of them (:meth:`add_tangent_node`)
        self._angles: dict[int, list[float]] = {i: [] for i in range(n)}
        self._keys: dict[int, list[object]] = {i: [] for i in range(n)}
        self._same: dict[object, object] = {}
        self.edges_geom: dict = {}
        self.targets: list[tuple[str, int]] = []
        # the circles each target may have a tangent or lie on, by circle (a target made at
        # circle ci is tried on circles ci, ci + 1, ...), with their checks asked in batches
        self.near_targets: dict[int, list[tuple[str, int]]] = {i: [] for i in range(n)}
        self.current = 0

    def add_tangent_node(self, ci: int, a: float) -> object | None:
        """The node of the tangent point at angle ``a`` on vertex ``ci``'s circle (None if it
        is not free). A point within ``SAME_ANGLE`` of a node already on the circle is that node,
        as in the lazy search's tables (:mod:`symrl.knowledge.circle_tables`): a point computed
        twice (the goal centre's tangent and the tangent from its leg's rim cut) may differ in
        the last bit, and the keys' rounding then tell them apart, and two nodes at one point
        would cut the circle's arcs there."""
        node = self.chk.tangent_node(ci, a)
        if node is None:
            return None
        p, key = node
        if key in self.pos:
            return key
        same = self._same.get(key)
        if same is not None:
            return same
        a = math.remainder(a, 2 * math.pi)
        angles, keys = self._angles[ci], self._keys[ci]
        k = bisect_left(angles, a)
        for j in (k - 1, k, 0, len(angles) - 1):  # the first and last: the same point near +-pi
            if 0 <= j < len(angles) and abs(math.remainder(angles[j] - a, 2 * math.pi)) <= SAME:
                self._same[key] = keys[j]
                return keys[j]
        angles.insert(k, a)
        keys.insert(k, key)
        self.pos[key] = p
        self.arcs_on[ci].append((a, key))
        return key

    def add_segment(self, u: object, v: object) -> None:
        a, b = self.pos[u], self.pos[v]
        if u != v and self.chk.segment_ok(a, b):
            self.graph.add_edge(u, v, weight=float(np.hypot(*(b - a))))
            self.edges_geom[frozenset((u, v))] = ("seg",)

    def new_target(self, q: np.ndarray) -> tuple[str, int]:
        chk = self.chk
        key = ("T", len(self.targets))
        self.pos[key] = q
        self.targets.append(key)
        circles = target_circles(chk, q, self.current)
        for ci in circles.tolist():
            self.near_targets[ci].append(key)
        requests = [(ci, a) for ci in circles.tolist() for a in chk.point_tangents(q, ci)]
        chk.prefetch_nodes(requests)
        nodes = (chk.nodes_cache[req] for req in requests)
        ends = [(node[0], q) for node in nodes if node is not None]
        chk.prefetch_segments(ends)
        return key

    def add_leg_to_centre(self, u: object) -> None:
        g, rg = self.g, self.rg
        p = self.pos[u]
        d = float(np.hypot(*(g - p)))
        if d <= rg:
            return
        q = g + (p - g) * (rg / d)
        if not self.chk.point_ok(q, tol=1e-7):
            return
        self.add_segment(u, self.new_target(q))

    def build(self) -> None:
        """Every node and free edge, in a fixed order (the route among equal ones depends on it)."""
        # targets: rim points where the rim meets the grown walls, and the rim cut of every leg
        # that points at the goal centre (from the start, and from tangents of the goal centre)
        for rim_point in self.chk.rim_targets(self.g, self.rg):
            self.new_target(rim_point)
        self.add_leg_to_centre("S")
        for t in list(self.targets):
            self.add_segment("S", t)
        prefetch_start_and_goal(self.chk, self.s, self.g, self.rg)
        for ci, c in enumerate(self.centres):
            self.current = ci
            self._add_circle(ci, c)
        for i, j, pairs in self.chk.bitangent_pairs():
            for a1, a2 in pairs:
                k1, k2 = self.add_tangent_node(i, a1), self.add_tangent_node(j, a2)
                if k1 is not None and k2 is not None:
                    self.add_segment(k1, k2)
        self._add_arcs()
        for t in self.targets:
            if t in self.graph:
                self.graph.add_edge(t, "GOAL", weight=0.0)

    def _add_circle(self, ci: int, c: np.ndarray) -> None:
        """The tangents from the start, the goal centre and the targets to vertex ``ci``'s
        circle, and the targets lying on it."""
        chk, r = self.chk, self.r
        for a in tangent_angles(self.s, c, r):
            k = self.add_tangent_node(ci, a)
            if k is not None:
                self.add_segment("S", k)
        for a in chk.point_tangents(self.g, ci):
            k = self.add_tangent_node(ci, a)
            if k is not None:
                self.add_leg_to_centre(k)
        for t in self.near_targets[ci]:
            tp = self.pos[t]
            if abs(float(np.hypot(*(tp - c))) - r) < 1e-6:  # the target lies on this circle
                a = math.atan2(tp[1] - c[1], tp[0] - c[0])
                self.arcs_on[ci].append((a, t))
                continue
            for a in chk.point_tangents(tp, ci):
                k = self.add_tangent_node(ci, a)
                if k is not None:
                    self.add_segment(k, t)

    def _add_arcs(self) -> None:
        """Arcs between neighbouring nodes on each circle (shorter than an edge already there);
        two nodes are neighbours both ways round, and the shorter free arc joins them."""
        for ci, nodes in self.arcs_on.items():
            nodes.sort(key=lambda t: t[0])
            m = len(nodes)
            arcs = []
            for idx in range(m):
                (a0, u), (a1, v) = nodes[idx], nodes[(idx + 1) % m]
                if idx == m - 1:
                    a1 += 2 * math.pi
                if u == v or a1 - a0 < 1e-12:
                    continue
                arcs.append((a0, a1, u, v))
            if not arcs:
                continue
            free = self.chk.arcs_ok(ci, [(a0, a1) for a0, a1, _, _ in arcs])
            for (a0, a1, u, v), ok in zip(arcs, free, strict=True):
                if ok:
                    w = self.r * (a1 - a0)
                    if not self.graph.has_edge(u, v) or self.graph[u][v]["weight"] > w:
                        self.graph.add_edge(u, v, weight=w)
                        self.edges_geom[frozenset((u, v))] = ("arc", ci, a0, a1)

    def shortest_route(self) -> tuple[float, list]:
        """Dijkstra's length and nodes from the start to the last target (``GOAL`` dropped);
        ``ValueError`` when no path exists."""
        graph = self.graph
        if "S" not in graph or "GOAL" not in graph:
            raise ValueError("no collision-free path from the start to the goal disc")
        try:
            length, route = nx.single_source_dijkstra(graph, "S", "GOAL")
        except nx.NetworkXNoPath:
            raise ValueError("no collision-free path from the start to the goal disc") from None
        return length, route[:-1]

    def polyline(self, route: list) -> np.ndarray:
        """The route as a polyline: segment end points and arcs sampled every ~5 mm."""
        pos, r, centres = self.pos, self.r, self.centres
        pts = [pos[route[0]]]
        for u, v in zip(route[:-1], route[1:], strict=False):
            g = self.edges_geom[frozenset((u, v))]
            if g[0] == "arc":
                _, ci, a0, a1 = g
                ang = np.linspace(a0, a1, max(2, int(math.ceil(r * (a1 - a0) / 0.005)) + 1))
                start, end = on_circle(centres[ci], r, a0).tolist(), pos[v].tolist()
                close = (
                    abs(x - y) <= 1e-6 + 1e-5 * abs(y) for x, y in zip(start, end, strict=True)
                )
                if all(close):
                    ang = ang[::-1]
                pts.extend(centres[ci] + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)[1:])
            else:
                pts.append(pos[v])
        return np.asarray(pts, dtype=float)
