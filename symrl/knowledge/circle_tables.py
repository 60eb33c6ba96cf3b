"""The tangent points of one vertex circle, built when the lazy search first reaches the circle.

:class:`CircleTables` answers, for vertex ``ci``'s circle of radius ``r``, the sorted angles of
every point where a shortest path may touch or leave it, each with its *exits*: the bitangent to
another circle, the leg to the goal centre (cut at the goal rim) or the tangent to a rim target.
Only tangents that pass the cone test at both ends are kept (:meth:`WallIndex.cone_ok`: the
line does not enter the walls at either vertex, so its nodes would be refused anyway); all of a
circle's bitangents are computed at once with numpy, in time linear in the corners.

The points the search leaves from the start, and reaches the goal from, are computed once for
every circle (:class:`Ends`), so the arrival angles are the table's floats bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from symrl.knowledge.path_checks import PathChecker

__all__ = ["CircleTable", "CircleTables", "Ends", "SAME_ANGLE"]

SAME_ANGLE = 1e-11
"""Radians within which two tangent points of a circle are the same node."""

NONE, BITANGENT, LEG, TO_TARGET, IS_TARGET = range(5)
"""Kinds of exit: none (a start tangent: only arrived at), a bitangent to circle ``partner``
at ``partner_angle``, the leg to the goal centre, a tangent to rim target ``target``, the rim
target ``target`` itself (it lies on the circle)."""


def point_tangents(p: np.ndarray, c: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Angles (around each centre of ``c`` (n, 2)) of the two tangent points from ``p``, and
    which exist (``p`` outside the circle): the same arithmetic as ``tangents.tangent_angles``."""
    v = p - c
    d = np.hypot(v[:, 0], v[:, 1])
    base = np.arctan2(v[:, 1], v[:, 0])
    off = np.arccos(np.minimum(1.0, r / np.maximum(d, 1e-300)))
    return np.stack([base + off, base - off], axis=1), (d >= r - 1e-12)[:, None].repeat(2, 1)


@dataclass
class Ends:
    """The start's and the goal's tangents to every circle, cone-tested: ``(n, k)`` angles and
    masks (k = 2 for the start and the goal centre, 2 per rim target)."""

    start: np.ndarray
    start_ok: np.ndarray
    goal: np.ndarray
    goal_ok: np.ndarray
    rim: np.ndarray
    rim_ok: np.ndarray
    rim_on: np.ndarray
    """(n, targets) the rim target lies on the circle."""

    @classmethod
    def of(
        cls,
        chk: PathChecker,
        s: np.ndarray,
        g: np.ndarray,
        rims: list[np.ndarray],
        among: np.ndarray | None = None,
    ) -> Ends:
        """With ``among``: the other circles' tangents are all refused."""
        c, r, n = chk.walls.vertices, chk.r, len(chk.walls.vertices)
        idx = np.arange(n)[:, None]
        allowed = np.ones((n, 1), bool)
        if among is not None:
            allowed[:] = False
            allowed[among] = True

        def cone(angles: np.ndarray, ok: np.ndarray) -> np.ndarray:
            return ok & allowed & chk.index.cone_ok(np.broadcast_to(idx, angles.shape), angles)

        sa, sok = point_tangents(s, c, r)
        ga, gok = point_tangents(g, c, r)
        ra, rok, on = np.zeros((n, 0)), np.zeros((n, 0), bool), np.zeros((n, len(rims)), bool)
        if rims:
            parts = [point_tangents(q, c, r) for q in rims]
            ra = np.concatenate([p[0] for p in parts], axis=1)
            rok = np.concatenate([p[1] for p in parts], axis=1)
            for t, q in enumerate(rims):
                on[:, t] = np.abs(np.hypot(*(q - c).T) - r) < 1e-6
            rok &= ~np.repeat(on, 2, axis=1)
        return cls(sa, cone(sa, sok), ga, cone(ga, gok), ra, cone(ra, rok), on)


@dataclass
class CircleTable:
    """One circle's nodes: ``angles`` sorted (one per node), and its exits grouped by node
    (rows ``first[k]:first[k + 1]`` of ``kind``, ``partner``, ``partner_angle``, ``target``)."""

    angles: np.ndarray
    first: np.ndarray
    kind: np.ndarray
    partner: np.ndarray
    partner_angle: np.ndarray
    target: np.ndarray
    free: np.ndarray
    """Each node's point is ``r`` clear of the walls."""
    arc_free: np.ndarray
    """The arc from node k to node k + 1 (the last: to the first) is clear."""

    def find(self, angle: float) -> int | None:
        """The node at ``angle`` (within :data:`SAME_ANGLE`), or None."""
        a = math.remainder(angle, 2 * math.pi)
        m = len(self.angles)
        k = int(np.searchsorted(self.angles, a))
        for j in (k - 1, k, 0, m - 1):  # the first and last: the same point near +-pi
            if (
                0 <= j < m
                and abs(math.remainder(self.angles[j] - a, 2 * math.pi)) <= 2 * SAME_ANGLE
            ):
                return j
        return None

    def exits(self, k: int) -> range:
        return range(int(self.first[k]), int(self.first[k + 1]))


class CircleTables:
    """:class:`CircleTable` of each circle, made when first asked for. With ``among`` (sorted
    vertex indices) the bitangents join those circles only (not remembered by the checker:
    they are not the circle's whole table)."""

    def __init__(
        self,
        chk: PathChecker,
        ends: Ends,
        rims: list[np.ndarray],
        among: np.ndarray | None = None,
    ) -> None:
        self.chk, self.ends, self.rims = chk, ends, rims
        self.c = chk.walls.vertices
        self.among = among
        self.tables: dict[int, CircleTable] = {}

    def __getitem__(self, ci: int) -> CircleTable:
        table = self.tables.get(ci)
        if table is None:
            table = self.tables[ci] = self._build(ci)
        return table

    def _bitangents(self, ci: int) -> tuple[np.ndarray, ...]:
        """(angle on ci, partner, angle on the partner) of every bitangent kept by the cone
        test at both ends; each pair's floats computed as for (lower index, higher index)."""
        c, r, n = self.c, self.chk.r, len(self.c)
        j = np.delete(np.arange(n), ci) if self.among is None else self.among[self.among != ci]
        low = j < ci
        v = np.where(low[:, None], c[ci] - c[j], c[j] - c[ci])
        d = np.hypot(v[:, 0], v[:, 1])
        base = np.arctan2(v[:, 1], v[:, 0])
        ratio = np.minimum(1.0, 2 * r / np.maximum(d, 1e-300))
        off = np.arccos(ratio)
        half = math.pi / 2
        first = np.stack([base + half, base - half, base + off, base - off], axis=1)
        second = np.stack(
            [base + half, base - half, base + off + math.pi, base - off + math.pi], axis=1
        )
        mine = np.where(low[:, None], second, first)
        theirs = np.where(low[:, None], first, second)
        # the cone tests take the directions' cosines and sines from the centres' offset (no
        # trigonometry on four angles a partner: a third of a table's time)
        with np.errstate(invalid="ignore", divide="ignore"):
            cb, sb = v[:, 0] / d, v[:, 1] / d
        so = np.sqrt(1.0 - ratio * ratio)
        cos_first = np.stack([-sb, sb, cb * ratio - sb * so, cb * ratio + sb * so], axis=1)
        sin_first = np.stack([cb, -cb, sb * ratio + cb * so, sb * ratio - cb * so], axis=1)
        flip = np.array([1.0, 1.0, -1.0, -1.0])  # the second circle's inner points: + pi
        lows = low[:, None]
        cos_mine = np.where(lows, cos_first * flip, cos_first)
        sin_mine = np.where(lows, sin_first * flip, sin_first)
        index = self.chk.index
        keep = index.cone_ok_cs(np.asarray(ci), cos_mine, sin_mine)  # one vertex's walls first
        keep[:, 2:] &= (d > 2 * r)[:, None]
        keep &= (d >= 1e-12)[:, None]
        rows, cols = np.nonzero(keep)
        mine, j, theirs = mine[rows, cols], j[rows], theirs[rows, cols]
        ct, st = cos_first[rows, cols], sin_first[rows, cols]
        theirs_flip = ~low[rows] & (cols >= 2)
        ct = np.where(theirs_flip, -ct, ct)
        st = np.where(theirs_flip, -st, st)
        far = index.cone_ok_cs(j, ct, st)
        mine, j, theirs = mine[far], j[far], theirs[far]
        a = c[ci] + r * np.stack([np.cos(mine), np.sin(mine)], axis=1)
        b = c[j] + r * np.stack([np.cos(theirs), np.sin(theirs)], axis=1)
        free = self.chk.segments_free(a, b, around=ci)
        return mine[free], j[free], theirs[free]

    def _build(self, ci: int) -> CircleTable:
        e = self.ends
        if self.among is None:
            ang, partner, p_ang = self.chk.circle_bitangents(ci, self._bitangents)
        else:
            ang, partner, p_ang = self._bitangents(ci)
        parts = [(ang, np.full(len(ang), BITANGENT), partner, p_ang, np.full(len(ang), -1))]
        ends = ((e.start[ci], e.start_ok[ci], NONE), (e.goal[ci], e.goal_ok[ci], LEG))
        for angles, ok, end_kind in ends:
            a = angles[ok]
            parts.append(
                (a, np.full(len(a), end_kind), np.full(len(a), -1), a, np.full(len(a), -1))
            )
        cols = np.flatnonzero(e.rim_ok[ci])
        a = e.rim[ci][cols]
        parts.append((a, np.full(len(a), TO_TARGET), np.full(len(a), -1), a, cols // 2))
        for t in np.flatnonzero(e.rim_on[ci]).tolist():
            q = self.rims[t]
            a = np.array([math.atan2(q[1] - self.c[ci][1], q[0] - self.c[ci][0])])
            parts.append((a, np.array([IS_TARGET]), np.array([-1]), a, np.array([t])))
        cat = [np.concatenate(x) for x in zip(*parts, strict=True)]
        cat[0] = np.remainder(cat[0] + math.pi, 2 * math.pi) - math.pi
        order = np.argsort(cat[0], kind="stable")
        angle, kinds, partners, p_angle, targets = (x[order] for x in cat)
        new = np.ones(len(angle), bool)
        new[1:] = np.diff(angle) > SAME_ANGLE
        first = np.append(np.flatnonzero(new), len(angle))
        nodes = angle[new]
        checks = self._checks(ci, nodes)
        return CircleTable(nodes, first, kinds, partners, p_angle, targets, *checks)

    def _checks(self, ci: int, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which nodes are free (as ``PathChecker.tangent_node``), and which arcs from node k to
        node k + 1 (the last to the first, round the circle) are, all at once."""
        chk, r, m = self.chk, self.chk.r, len(nodes)
        pts = self.c[ci] + r * np.stack([np.cos(nodes), np.sin(nodes)], axis=1)
        free = chk.world.contains_xy(pts[:, 0], pts[:, 1]) & (
            chk.index.points_clearance_closest(pts) >= r - 1e-7
        )
        if m < 2:
            return free, np.zeros(m, bool)
        spans = [(float(a), float(b)) for a, b in zip(nodes[:-1], nodes[1:], strict=True)]
        spans.append((float(nodes[-1]), float(nodes[0]) + 2 * math.pi))
        return free, np.array(chk.arcs_ok(ci, spans), dtype=bool)
