"""A* over the tangent visibility graph, built as it is searched: cost grows with what it explores.

The graph is the one :class:`~symrl.knowledge.tangent_graph.TangentGraph` builds whole (the start,
tangent points on the vertex circles, rim targets, joined by free segments and arcs), but a
circle's tangent points are computed only when the search first reaches the circle
(:class:`~symrl.knowledge.circle_tables.CircleTables`, numpy over all corners at once), and a
node's successors only when it is expanded: the arcs to its neighbours on its circle, its
bitangent(s), and its leg to the goal. Collision checks are lazy: an edge is pushed with its
length and checked (:class:`~symrl.knowledge.path_checks.PathChecker`, remembered) only when it
comes off the queue, so edges whose optimistic cost could not improve the search are never
checked. Deleting an entry whose edge is blocked leaves A*'s order on the free graph.

The heuristic is the straight-line distance to the goal rim, or, given a
:class:`~symrl.knowledge.grid_bound.GridBound`, the larger of that and the bound, which knows the
walls (on a 5,230-corner floor A* then opens about a fifth as many circles). Both stay below the
true remaining length (admissible); the straight line is also consistent, the grid bound need not
be, so a node reached again by a shorter way is expanded again (:data:`REOPEN`). Either way the
first time the goal comes off the queue its length is the shortest one.

The arcs join neighbouring tangent points of a circle that some edge can leave or reach; the
whole graph also holds points whose bitangent fails the cone test at the far end: they split an
arc in pieces of the same total length. Among equal-length routes this search may pick another
one than the whole graph's Dijkstra.
"""

from __future__ import annotations

import heapq
import itertools
import math
from typing import Any

import numpy as np

from symrl.knowledge.circle_tables import (
    BITANGENT,
    IS_TARGET,
    LEG,
    TO_TARGET,
    CircleTables,
    Ends,
)
from symrl.knowledge.grid_bound import GridBound
from symrl.knowledge.path_checks import PathChecker
from symrl.knowledge.tangents import on_circle

__all__ = ["LazySearch"]

Node = Any
"""``"S"``, ``"GOAL"`` or a tuple: ``("C", circle, k)``, ``("T", t)``, ``("L", node)``."""
Edge = tuple[Any, ...] | None

_NO_PATH = "no collision-free path from the start to the goal disc"
REOPEN = 1e-9
"""Metres by which a node reached again must be shorter to be expanded again (with a
:class:`GridBound`, which is not consistent, a node may first be reached by a longer way)."""


class LazySearch:
    """One search from ``s`` into the goal disc ``(g, rg)``: :meth:`run` gives the length and
    the route; :meth:`polyline` its geometry. Nodes: ``"S"``, ``("C", circle, k)`` (k-th
    tangent point of the circle's table), ``("T", t)`` rim targets, ``("L", ...)`` the rim cut
    of a leg that points at the goal centre, ``"GOAL"``. With ``among`` (sorted vertex
    indices) the path may touch those corners' circles only: the shortest such path, every
    edge still checked against every wall. ``bound``: a :class:`GridBound` to the same goal
    disc at clearance ``chk.r`` or less, the heuristic's wall-aware part."""

    def __init__(
        self,
        chk: PathChecker,
        s: np.ndarray,
        g: np.ndarray,
        rg: float,
        among: np.ndarray | None = None,
        bound: GridBound | None = None,
    ) -> None:
        self.chk, self.r = chk, chk.r
        self.bound = bound
        self.s, self.g, self.rg = s, g, rg
        self.c = chk.walls.vertices
        self.rims = chk.rim_targets(g, rg)
        self.ends = Ends.of(chk, s, g, self.rims, among)
        self.tables = CircleTables(chk, self.ends, self.rims, among)
        # walls near the start and the goal: a segment from the start, or into the goal disc,
        # that crosses one is refused before the full check
        self._near = {"S": chk.index.near_rings(s), "G": chk.index.near_rings(g)}
        self.pos: dict[Node, np.ndarray] = {"S": s}
        self.closed: dict[Node, tuple[float, Node, Edge]] = {}
        self._heap: list = []
        self._seq = itertools.count()

    # --- the queue ----------------------------------------------------------------------------

    def _push(
        self,
        g0: float,
        cost: float,
        ref: Node,
        end: np.ndarray | None,
        parent: Node,
        edge: Edge,
    ) -> None:
        g1 = g0 + cost
        h = 0.0
        if end is not None:
            x, y = float(end[0]), float(end[1])
            h = max(0.0, math.hypot(x - self.g[0], y - self.g[1]) - self.rg)
            if self.bound is not None:
                h = max(h, self.bound.at(x, y))
        heapq.heappush(self._heap, (g1 + h, g1, next(self._seq), ref, parent, edge))

    def run(self) -> tuple[float, list]:
        """The shortest length and its nodes (``GOAL`` dropped); ``ValueError`` if none."""
        self._expand_start()
        heap, closed = self._heap, self.closed
        while heap:
            _, g1, _, ref, parent, edge = heapq.heappop(heap)
            if not self._edge_free(edge):  # first: a blocked edge builds no circle's table
                continue
            node = self._resolve(ref)
            if node is None or not self._node_free(node):
                continue
            seen = closed.get(node)
            if seen is not None and g1 >= seen[0] - REOPEN:
                continue
            closed[node] = (g1, parent, edge)
            if node == "GOAL":
                return g1, self._route()
            self._expand(node, g1)
        raise ValueError(_NO_PATH)

    def _resolve(self, ref: Node) -> Node | None:
        """A pushed ``("c", circle, angle)`` as its node of the circle's table (or None)."""
        if isinstance(ref, tuple) and ref[0] == "c":
            _, ci, a = ref
            k = self.tables[ci].find(a)
            if k is None:
                return None
            node = ("C", ci, k)
            if node not in self.pos:
                self.pos[node] = on_circle(self.c[ci], self.r, float(self.tables[ci].angles[k]))
            return node
        return ref

    def _node_free(self, node: Node) -> bool:
        return not (node[0] == "C" and not self.tables[node[1]].free[node[2]])

    def _edge_free(self, edge: Edge) -> bool:
        """The check of the edge an entry was pushed with (bitangents and arcs: checked with
        their circle's table)."""
        if edge is None or edge[0] in ("arc", "free"):
            return True
        near = self._near["S" if edge[1] is self.s else "G"]
        if edge[0] == "seg":
            return self.chk.segment_ok(edge[1], edge[2], near=near)
        return self.chk.point_ok(edge[2], tol=1e-7) and self.chk.segment_ok(
            edge[1], edge[2], near=near
        )

    # --- successors -----------------------------------------------------------------------------

    def _expand_start(self) -> None:
        s, e, r = self.s, self.ends, self.r
        ci, col = np.nonzero(e.start_ok)
        ang = e.start[ci, col]
        pts = self.c[ci] + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        dist = np.hypot(*(pts - s).T)
        for i, a, p, d in zip(ci.tolist(), ang.tolist(), pts, dist.tolist(), strict=True):
            self._push(0.0, d, ("c", i, a), p, "S", ("seg", s, p))
        self._leg("S", s, 0.0)
        for t, q in enumerate(self.rims):
            self.pos[("T", t)] = q
            self._push(0.0, math.hypot(*(q - s)), ("T", t), None, "S", ("seg", s, q))

    def _leg(self, node: Node, p: np.ndarray, g0: float) -> None:
        """The leg from ``p`` towards the goal centre, cut at the rim."""
        d = math.hypot(*(self.g - p))
        if d > self.rg:
            q = self.g + (p - self.g) * (self.rg / d)
            self.pos[("L", node)] = q
            self._push(g0, d - self.rg, ("L", node), None, node, ("leg", p, q))

    def _expand(self, node: Node, g0: float) -> None:
        if node == "S":
            return
        if node[0] in ("T", "L"):
            self._push(g0, 0.0, "GOAL", None, node, None)
            return
        _, ci, k = node
        table, p, r = self.tables[ci], self.pos[node], self.r
        ang = table.angles
        m = len(ang)
        if m >= 2:
            nxt, prv = (k + 1) % m, (k - 1) % m
            for j, arc, ccw in ((nxt, k, True), (prv, prv, False)):
                if not (table.arc_free[arc] and table.free[j]):
                    continue
                lo, hi = float(ang[arc]), float(ang[(arc + 1) % m])
                if arc == m - 1:  # round the circle: the last node to the first
                    hi += 2 * math.pi
                if hi - lo < 1e-12:
                    continue
                end = on_circle(self.c[ci], r, float(ang[j]))
                arc_edge = ("arc", ci, lo, hi, ccw)
                self._push(g0, r * (hi - lo), ("c", ci, float(ang[j])), end, node, arc_edge)
        for row in table.exits(k):
            kind = int(table.kind[row])
            if kind == BITANGENT:
                cj, aj = int(table.partner[row]), float(table.partner_angle[row])
                q = on_circle(self.c[cj], r, aj)
                # checked with the circle's table: no edge to check
                self._push(g0, math.hypot(*(q - p)), ("c", cj, aj), q, node, ("free", p, q))
            elif kind == LEG:
                self._leg(node, p, g0)
            elif kind in (TO_TARGET, IS_TARGET):
                t = int(table.target[row])
                q = self.rims[t]
                self.pos[("T", t)] = q
                edge: Edge = ("seg", p, q) if kind == TO_TARGET else None
                cost = math.hypot(*(q - p)) if kind == TO_TARGET else 0.0
                self._push(g0, cost, ("T", t), None, node, edge)

    # --- the result -----------------------------------------------------------------------------

    def _route(self) -> list:
        route, node = [], self.closed["GOAL"][1]
        while node is not None and node != "S":
            route.append(node)
            node = self.closed[node][1]
        route.append("S")
        return route[::-1]

    def polyline(self, route: list) -> np.ndarray:
        """The route as a polyline: segment end points and arcs sampled every ~5 mm."""
        pts = [self.pos[route[0]]]
        for node in route[1:]:
            edge = self.closed[node][2]
            if edge is None:
                continue
            if edge[0] == "arc":
                _, ci, a0, a1, ccw = edge
                n = max(2, int(math.ceil(self.r * (a1 - a0) / 0.005)) + 1)
                ang = np.linspace(a0, a1, n) if ccw else np.linspace(a1, a0, n)
                ring = np.stack([np.cos(ang), np.sin(ang)], axis=1)
                pts.extend(self.c[ci] + self.r * ring[1:])
            else:
                pts.append(self.pos[node])
        return np.asarray(pts, dtype=float)
