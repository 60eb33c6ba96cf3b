"""Sub-goals from the region rules alone: where the regions border each other, and which border
leads on toward the goal's region.

This is what a robot told only the paper's symbolic knowledge (``knowledge: regions``) can
derive: the rules name lines and say on which side of each line each region lies, so they fix
where two regions meet (a *border*: a stretch of a line with one region on each side) and which
regions border which (the *region graph*). They say nothing of walls: a border may be open floor
or a wall with a door in it. The paper's lines are drawn at the world's joints (the door posts),
so a border's finite end is where a wall may begin; a point kept ``inset`` from it is where a
robot can hope to cross.

Per region, the options are the goal and, for every neighbour no farther from the goal's region
in the region graph (hops), one point of their border: the point of the border nearest the goal,
at least ``inset`` from the border's finite ends (its middle when it is shorter), moved
``beyond`` past the line into the neighbour. Which option pays is learned by the option critic
(:class:`symrl.learner.options.SubgoalOptions`), from the robot's own returns.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from symrl.knowledge.subgoals import SubgoalTable, find_passages
from symrl.world.worldmap import Goal, RegionSpec, WorldMap

__all__ = [
    "Border",
    "region_borders",
    "passages_of",
    "region_hops",
    "goal_region",
    "hops_from",
    "border_subgoals",
    "BorderOptions",
    "border_options",
]


@dataclass(frozen=True)
class Border:
    """Line ``line`` (``axis`` 0: x = ``intercept``, running along y) separates region ``low``
    (the side of smaller coordinate ``axis``) from ``high`` for ``lo < t < hi`` along it (t the
    other coordinate; either end may be infinite)."""

    line: str
    axis: int
    intercept: float
    lo: float
    hi: float
    low: str
    high: str

    def at(self, t: float, offset: float = 0.0) -> tuple[float, float]:
        """The point ``t`` along the line, ``offset`` metres off it (+: toward ``high``)."""
        c = self.intercept + offset
        return (c, t) if self.axis == 0 else (t, c)


def _breaks(spec: RegionSpec, axis: int) -> list[float]:
    """The thresholds the rules compare coordinate ``axis`` with: where, along a line of the
    other axis, the region on either side can change."""
    return sorted({c.threshold for r in spec.rules for c in r.conditions if c.axis == axis})


def region_borders(spec: RegionSpec, eps: float = 1e-6) -> list[Border]:
    """Every stretch of a named line with a different region on each side (from the rules)."""
    out: list[Border] = []
    for name, (axis_name, c) in spec.lines.items():
        axis = 0 if axis_name == "x" else 1
        cuts = [-math.inf, *_breaks(spec, 1 - axis), math.inf]
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            if hi - lo <= 2 * eps:
                continue
            mid = (
                (lo + hi) / 2
                if math.isfinite(lo + hi)
                else (hi - 1.0 if math.isfinite(hi) else lo + 1.0 if math.isfinite(lo) else 0.0)
            )
            sides = []
            for off in (-eps, eps):
                xy = (c + off, mid) if axis == 0 else (mid, c + off)
                sides.append(spec.region_of(*xy))
            if sides[0] == sides[1]:
                continue
            last = out[-1] if out else None
            if (
                last is not None
                and last.line == name
                and last.hi == lo
                and (last.low, last.high) == tuple(sides)
            ):
                out[-1] = Border(name, axis, c, last.lo, hi, sides[0], sides[1])
            else:
                out.append(Border(name, axis, c, lo, hi, sides[0], sides[1]))
    return out


def passages_of(world: WorldMap) -> tuple[Border, ...]:
    """The map tool of the ``passages`` rung: where the region lines cross free space between
    two regions (``symrl.knowledge.subgoals.find_passages``, which reads the walls), as
    ``Border``s that hold no geometry but the line, the stretch and the two regions."""
    out = []
    for p in find_passages(world):
        low, high = (p.before, p.after) if p.normal > 0 else (p.after, p.before)
        out.append(Border(p.line, p.axis, p.intercept, p.lo, p.hi, low, high))
    return tuple(out)


def region_hops(spec: RegionSpec, borders: Sequence[Border], goal: Goal) -> dict[str, int]:
    """Each region's distance from the goal's region in the region graph, in borders crossed
    (a region with no way there is left out)."""
    return hops_from(goal_region(spec, goal), borders)


_NUDGE = 1e-6
"""Metres off the goal's centre at which :func:`goal_region` looks round it."""


def goal_region(spec: RegionSpec, goal: Goal) -> str:
    """The region of the goal's centre, unless none of the four points a micrometre off it
    diagonally lies in that region: the centre is on a line, which the rules' strict
    comparisons leave to a later rule (often the default, elsewhere on the map); then the
    region most of those four points lie in (on a tie, the one north-east of the centre)."""
    x, y, e = float(goal.x), float(goal.y), _NUDGE
    centre = spec.region_of(x, y)
    around = spec.regions_of(
        np.array([x + e, x - e, x + e, x - e]), np.array([y + e, y + e, y - e, y - e])
    )
    if centre in around:
        return centre
    return max(around, key=lambda name: (around.count(name), -around.index(name)))


def hops_from(target: str, borders: Sequence[Border]) -> dict[str, int]:
    """Each region's distance from ``target`` over ``borders``, in borders crossed (a region
    with no way there is left out)."""
    hops = {target: 0}
    queue = deque([target])
    while queue:
        here = queue.popleft()
        for b in borders:
            for a, z in ((b.low, b.high), (b.high, b.low)):
                if a == here and z not in hops:
                    hops[z] = hops[here] + 1
                    queue.append(z)
    return hops


def border_subgoals(
    spec: RegionSpec,
    goal: Goal,
    borders: Sequence[Border] | None = None,
    inset: float = 0.5,
    beyond: float = 0.4,
    merge: float = 0.3,
) -> SubgoalTable:
    """Per region (in the order of ``spec.names``): the goal, then one point of each border
    with a neighbour no farther from the goal's region (see the module docstring). ``borders``:
    the region rules' (default), or the passages a robot is told of. Points closer than
    ``merge`` to an earlier option of the region are dropped."""
    borders = list(region_borders(spec) if borders is None else borders)
    hops = region_hops(spec, borders, goal)
    g = (float(goal.x), float(goal.y))
    per_region: list[list[tuple[tuple[float, float], str]]] = []
    for region in spec.names:
        cands: list[tuple[tuple[float, float], str]] = [(g, "goal")]
        mine = hops.get(region, math.inf)
        for b in borders:
            if region not in (b.low, b.high):
                continue
            other = b.high if region == b.low else b.low
            if hops.get(other, math.inf) > mine:
                continue
            goal_t = g[1] if b.axis == 0 else g[0]
            if b.hi - b.lo <= 2 * inset:
                t = (b.lo + b.hi) / 2
            else:
                t = min(max(goal_t, b.lo + inset), b.hi - inset)
            xy = b.at(t, beyond if other == b.high else -beyond)
            if any(math.dist(xy, q) < merge for q, _ in cands):
                continue
            cands.append((xy, f"{b.line}>{other}"))
        per_region.append(cands)
    return SubgoalTable.of(tuple(spec.names), per_region)


@dataclass(frozen=True)
class BorderOptions:
    """Every border of every region as an option, for a robot that learns where each can be
    crossed (``symrl.learner.crossings``): ``table`` holds, per region, the goal and then one
    option per border of the region (its point as :func:`border_subgoals` places it, the start
    of the robot's search); ``border[r][k]`` is the index in ``borders`` of option k of region
    r (-1: the goal), ``side[r][k]`` +1 when the option leads to the border's ``high`` side."""

    table: SubgoalTable
    borders: tuple[Border, ...]
    border: tuple[tuple[int, ...], ...]
    side: tuple[tuple[float, ...], ...]


def border_options(
    spec: RegionSpec,
    goal: Goal,
    borders: Sequence[Border] | None = None,
    inset: float = 0.5,
    beyond: float = 0.4,
) -> BorderOptions:
    """Per region (in the order of ``spec.names``): the goal, then every border of the region,
    whichever way it leads (which ones lead on toward the goal is the robot's to find out, as
    it learns which borders are walls)."""
    borders = tuple(region_borders(spec) if borders is None else borders)
    g = (float(goal.x), float(goal.y))
    per_region, index, sides = [], [], []
    for region in spec.names:
        cands: list[tuple[tuple[float, float], str]] = [(g, "goal")]
        ids, signs = [-1], [0.0]
        for j, b in enumerate(borders):
            if region not in (b.low, b.high):
                continue
            other = b.high if region == b.low else b.low
            goal_t = g[1] if b.axis == 0 else g[0]
            if b.hi - b.lo <= 2 * inset:
                t = (b.lo + b.hi) / 2
            else:
                t = min(max(goal_t, b.lo + inset), b.hi - inset)
            sign = 1.0 if other == b.high else -1.0
            cands.append((b.at(t, sign * beyond), f"{b.line}>{other}"))
            ids.append(j)
            signs.append(sign)
        per_region.append(cands)
        index.append(tuple(ids))
        sides.append(tuple(signs))
    table = SubgoalTable.of(tuple(spec.names), per_region)
    return BorderOptions(table, borders, tuple(index), tuple(sides))
