"""Start poses and a new obstacle taken from a map, for studies on worlds other than the paper's.

The paper's world keeps its hand-picked poses (``OTHER_STARTS``, ``generalisation.STARTS``) and
its box (``generalisation.OBSTACLE``). Any other map gets them from its walls, without randomness:

- **Start poses** (:func:`map_starts`): the map's ``starts:`` list if it has one; otherwise
  :func:`derived_starts`, free points of a fixed 0.25 m grid with clearance > body radius +
  ``margin``, connected to the start for the body, outside the goal disc (plus a margin), in the
  start's region or a region next to it, picked by farthest-point choice from the start (ties:
  grid order). Each faces the goal.
- **New obstacle** (:func:`derived_obstacle`): a square box centred on the planner's shortest
  path about a third of the way, clear of the start and the goal disc, inside the free area,
  touching no thin wall, with the goal still reachable (``worldmap.reaches_goal``); other
  fractions and smaller boxes are tried in a fixed order when one does not fit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString, Point, box

from symrl.knowledge.planner import shortest_path
from symrl.world.worldmap import BODY_RADIUS, WorldMap, reaches_goal

__all__ = [
    "OTHER_STARTS",
    "GRID",
    "map_starts",
    "derived_starts",
    "derived_obstacle",
    "study_starts",
    "near_start",
]

GRID = 0.25
"""Spacing (metres) of the candidate grid for derived start poses."""

Pose3 = tuple[float, float, float]

OTHER_STARTS: tuple[Pose3, ...] = (
    (-1.0, 1.5, 0.0),
    (1.0, -1.8, 0.0),
    (2.0, 1.5, -math.pi / 2),
    (-0.8, -1.0, math.pi / 4),
)
"""Four start poses in the paper's room for the final controller (Fig. 5 bottom right)."""


def _walls(world: WorldMap) -> MultiLineString:
    return MultiLineString([[(a, b), (c, d)] for a, b, c, d in world.segments])


def _candidates(world: WorldMap, margin: float) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Grid points with clearance, reachable from the start for the body: (points, regions,
    grid adjacency lists as an index array of neighbours)."""
    xmin, xmax, ymin, ymax = world.bounds
    xs = np.arange(math.ceil(xmin / GRID), math.floor(xmax / GRID) + 1) * GRID
    ys = np.arange(math.ceil(ymin / GRID), math.floor(ymax / GRID) + 1) * GRID
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    gx, gy = gx.ravel().round(6), gy.ravel().round(6)
    ok = world.contains_xy(gx, gy)
    clear = shapely.distance(_walls(world), shapely.points(gx, gy)) > BODY_RADIUS + margin
    g = world.goal
    away = np.hypot(gx - g.x, gy - g.y) > g.radius + margin + BODY_RADIUS
    keep = ok & clear & away
    pts = np.stack([gx[keep], gy[keep]], axis=1)
    # flood fill over grid neighbours from the point nearest the start: two neighbouring points
    # both farther than the step from every wall have no wall between them
    key = {(round(x / GRID), round(y / GRID)): i for i, (x, y) in enumerate(pts)}
    if not len(pts):
        return pts, [], np.zeros(0, dtype=bool)
    s = world.start
    seed = int(np.argmin(np.hypot(pts[:, 0] - s.x, pts[:, 1] - s.y)))
    reached = np.zeros(len(pts), dtype=bool)
    reached[seed] = True
    stack = [seed]
    while stack:
        i = stack.pop()
        cx, cy = round(pts[i, 0] / GRID), round(pts[i, 1] / GRID)
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            j = key.get((cx + dx, cy + dy))
            if j is not None and not reached[j]:
                reached[j] = True
                stack.append(j)
    pts = pts[reached]
    regions = world.regions.regions_of(pts[:, 0], pts[:, 1])
    return pts, regions, reached


def _neighbour_regions(world: WorldMap, pts: np.ndarray, regions: list[str]) -> set[str]:
    """The start's region and the regions of grid points next to one of its points."""
    home = world.regions.region_of(world.start.x, world.start.y)
    key = {(round(x / GRID), round(y / GRID)): r for (x, y), r in zip(pts, regions, strict=True)}
    out = {home}
    for (cx, cy), r in key.items():
        if r != home:
            continue
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            other = key.get((cx + dx, cy + dy))
            if other is not None:
                out.add(other)
    return out


def _farthest(pts: np.ndarray, taken: list[tuple[float, float]], n: int) -> list[int]:
    """``n`` indices chosen one by one, each the farthest from everything chosen so far."""
    if not len(pts):
        return []
    d = np.full(len(pts), np.inf)
    for x, y in taken:
        d = np.minimum(d, np.hypot(pts[:, 0] - x, pts[:, 1] - y))
    picks: list[int] = []
    for _ in range(min(n, len(pts))):
        i = int(np.argmax(d))
        if picks and d[i] <= 0:
            break
        picks.append(i)
        d = np.minimum(d, np.hypot(pts[:, 0] - pts[i, 0], pts[:, 1] - pts[i, 1]))
    return picks


def _facing_goal(world: WorldMap, x: float, y: float) -> Pose3:
    g = world.goal
    return (round(float(x), 4), round(float(y), 4), math.atan2(g.y - y, g.x - x))


def derived_starts(
    world: WorldMap, n: int = 4, margin: float = 0.1, near: bool = True
) -> tuple[Pose3, ...]:
    """``n`` free start poses from the walls, spread by farthest-point choice: in the start's
    region and its neighbouring regions (``near``), or in the other regions (``near=False``;
    fewer or none when the map has no other region the start connects to)."""
    pts, regions, _ = _candidates(world, margin)
    if not len(pts):
        return ()
    close = _neighbour_regions(world, pts, regions)
    mask = np.array([(r in close) == near for r in regions])
    pool = pts[mask]
    s = world.start
    picks = _farthest(pool, [(s.x, s.y)], n)
    return tuple(_facing_goal(world, *pool[i]) for i in picks)


def near_start(world: WorldMap, pose: Pose3, margin: float = 0.1) -> bool:
    """Whether ``pose`` lies in the start's region or a region next to it."""
    pts, regions, _ = _candidates(world, margin)
    return world.regions.region_of(pose[0], pose[1]) in _neighbour_regions(world, pts, regions)


def map_starts(world: WorldMap, n: int = 4) -> tuple[Pose3, ...]:
    """The map's own ``starts:`` if it lists any, else :func:`derived_starts`."""
    if world.starts:
        return tuple((p.x, p.y, p.heading) for p in world.starts)
    return derived_starts(world, n)


def study_starts(world: WorldMap) -> tuple[Pose3, ...]:
    """The other start poses of ``symrl study`` / ``ablate``: the paper's four on its own world,
    the map's (listed or derived) elsewhere."""
    return OTHER_STARTS if world.name == "hailu2001" else map_starts(world)


def derived_obstacle(
    world: WorldMap,
    fractions: tuple[float, ...] = (1 / 3, 0.3, 0.4, 0.25, 0.45, 0.5, 0.2, 0.55, 0.6),
    sizes: tuple[float, ...] = (0.5, 0.4, 0.3),
    margin: float = 0.1,
) -> list[list[float]] | None:
    """A square box (side ``size``) centred on the shortest path at ``fraction`` of its length,
    the first (size, fraction) in order that fits: clear of the start by the body radius +
    ``margin``, clear of the goal disc by the same, inside the free area, off every thin wall,
    and leaving the goal reachable. None if no candidate fits."""
    plan = shortest_path(world)
    line = LineString(np.asarray(plan.points, dtype=float).reshape(-1, 2))
    free = world.free_polygon
    thin = [LineString([(a, b), (c, d)]) for a, b, c, d in world.extra_segments]
    s, g = world.start, world.goal
    for size in sizes:
        for frac in fractions:
            c = line.interpolate(frac, normalized=True)
            h = size / 2
            poly = box(c.x - h, c.y - h, c.x + h, c.y + h)
            if poly.distance(Point(s.x, s.y)) <= BODY_RADIUS + margin:
                continue
            if poly.distance(Point(g.x, g.y)) <= g.radius + BODY_RADIUS + margin:
                continue
            if not free.contains(poly) or any(poly.intersects(t) for t in thin):
                continue
            corners = [
                [round(float(x), 4), round(float(y), 4)] for x, y in list(poly.exterior.coords)[:-1]
            ]
            if reaches_goal(world.with_obstacle(corners)):
                return corners
    return None


def describe(pose: Any) -> str:
    """``(x, y, heading deg)`` for tables."""
    x, y, h = pose
    return f"({x:g}, {y:g}, {math.degrees(h):.0f} deg)"
