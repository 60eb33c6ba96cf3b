"""Whole-map checks for meaning: what a well-formed map can still get wrong, and its size limits.

The robot's body fits at the start and can reach the goal, obstacles lie inside the boundary,
every region rule can fire (:func:`check_meaning`); a map is small enough to find its regions
from the walls, or to plan on (:func:`check_plannable`). They use shapely (GEOS): exact, and fast
on big polygons.
"""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import LineString, MultiLineString, Point, Polygon
from shapely.ops import unary_union

from symrl.world.map_fields import MapError, short_repr
from symrl.world.map_model import WorldMap
from symrl.world.map_regions import check_regions

__all__ = [
    "BODY_RADIUS",
    "MAX_AUTO_CORNERS",
    "MAX_AUTO_PIECES",
    "MAX_PLAN_AREA",
    "MAX_PLAN_CORNERS",
    "check_auto_size",
    "check_meaning",
    "check_plannable",
    "check_room",
    "planning_note",
    "reaches_goal",
]

BODY_RADIUS = 0.26
"""The B21's body radius (metres): the start must be this far from every wall and the goal
reachable by a disc this size. ``RobotConfig.radius`` has the same default."""

MAX_PLAN_CORNERS = 5500
"""Most wall corners (polygon vertices, two per thin wall) a map the planner and the sub-goal
table work on may have. Above 100 corners the planner builds its graph only where its A* search
reaches, guided by a grid bound that knows the walls (``symrl.knowledge.grid_bound``), so its
time grows with the part of the map the path explores (office floors, one plan in a fresh
process, CPU seconds on a shared machine: 642 corners 0.14 s, 1,966 corners 0.75 s, 2,742
corners 1.3 s, 5,230 corners 3.1 s, the grid included; ``symrl plan``, two plans and a replay,
6.5-7 s there). Larger maps have not been measured with the grid bound."""
MAX_PLAN_AREA = 250_000.0
"""Largest bounding box (m^2) of a map the sub-goal table works on: its look-out grid (one
point per 0.2 m) grows with the area (a 400 m square: 1 s and 0.5 GB; 2 km: 32 s and 3.5 GB)."""

MAX_AUTO_PIECES = 100
"""Most obstacles plus segments a map may have when its regions are found from the walls
(``regions: auto``): the search grows with their square (100: a few seconds)."""
MAX_AUTO_CORNERS = 20_000
"""Most polygon corners a map may have when its regions are found from the walls."""


def check_room(boundary: np.ndarray) -> None:
    """The free area must hold the robot's body, before anything is computed in it."""
    width, height = (float(v) for v in np.ptp(boundary, axis=0))
    if min(width, height) < 2 * BODY_RADIUS:
        raise MapError(
            f"field 'boundary': the room spans only {width:.3g} x {height:.3g} m; the robot's body "
            f"(radius {BODY_RADIUS} m) does not fit in it"
        )


def check_auto_size(
    boundary: np.ndarray, obstacles: tuple[np.ndarray, ...], segments: np.ndarray
) -> None:
    """Refuse, before the search starts, a map too large to find its regions in."""
    pieces = len(obstacles) + len(segments)
    corners = len(boundary) + sum(len(p) for p in obstacles)
    if pieces > MAX_AUTO_PIECES or corners > MAX_AUTO_CORNERS:
        raise MapError(
            f"map with {len(obstacles)} obstacles, {len(segments)} segments and {corners} "
            f"corners: too large to find its regions from the walls (at most {MAX_AUTO_PIECES} "
            f"obstacles and segments and {MAX_AUTO_CORNERS} corners); write its regions: rules"
        )


def check_meaning(world: WorldMap, source: str) -> None:
    """Faults a well-formed map can still have: things a robot or the region rules cannot do."""
    where = f"{source}: field"
    outer = Polygon(world.boundary)
    for i, poly in enumerate(world.obstacles):
        if not outer.covers(Polygon(poly)):
            raise MapError(
                f"{where} 'obstacles[{i}]': the polygon {short_repr(poly.tolist())} is not inside "
                "the boundary"
            )
    for i, (x0, y0, x1, y1) in enumerate(world.extra_segments):
        if not outer.covers(LineString([(x0, y0), (x1, y1)])):
            raise MapError(
                f"{where} 'segments[{i}]': [[{x0}, {y0}], [{x1}, {y1}]] leaves the boundary"
            )

    start, goal = world.start, world.goal
    gap = math.hypot(start.x - goal.x, start.y - goal.y)
    if gap <= goal.radius:
        raise MapError(
            f"{where} 'goal': the goal disc (centre ({goal.x}, {goal.y}), radius {goal.radius}) "
            f"covers the start ({start.x}, {start.y}); a trial would end before it begins"
        )
    walls = MultiLineString([[(a, b), (c, d)] for a, b, c, d in world.segments])
    poses = [("start", start)] + [(f"starts[{i}]", p) for i, p in enumerate(world.starts)]
    for label, pose in poses[1:]:
        if math.hypot(pose.x - goal.x, pose.y - goal.y) <= goal.radius:
            raise MapError(f"{where} {label!r}: ({pose.x}, {pose.y}) is inside the goal disc")
    for label, pose in poses:
        clearance = walls.distance(Point(pose.x, pose.y))
        if clearance < BODY_RADIUS:
            raise MapError(
                f"{where} {label!r}: ({pose.x}, {pose.y}) is {clearance:.3f} m from the nearest "
                f"wall, closer than the robot's body radius {BODY_RADIUS} m"
            )
    for label, pose in poses:
        if not reaches_goal(world, (pose.x, pose.y)):
            raise MapError(
                f"{where} 'goal': the goal disc (centre ({goal.x}, {goal.y}), radius "
                f"{goal.radius}) cannot be reached from the {label.replace('s[', ' pose [')} "
                f"({pose.x}, {pose.y}) by the robot's body (radius {BODY_RADIUS} m): a passage "
                "on the way is too narrow or closed"
            )
    check_regions(world.regions, world.bounds, world.free_polygon, source)


def _corners_and_area(world: WorldMap) -> tuple[int, float]:
    xmin, xmax, ymin, ymax = world.bounds
    return len(world.segments) + len(world.extra_segments), (xmax - xmin) * (ymax - ymin)


def check_plannable(world: WorldMap) -> None:
    """Refuse, in one line naming the limit, a map too big for the planner and the sub-goal
    table (:data:`MAX_PLAN_CORNERS`, :data:`MAX_PLAN_AREA`), before they start: beyond them
    they take minutes and gigabytes. The simulator and the reflex have no such limit."""
    corners, area = _corners_and_area(world)
    if corners > MAX_PLAN_CORNERS:
        raise MapError(
            f"map {world.name!r}: {corners} wall corners, more than the {MAX_PLAN_CORNERS} the "
            "planner and the sub-goal table work on (measured up to 5,230: a plan in about 3 s); "
            "simplify the walls"
        )
    if area > MAX_PLAN_AREA:
        raise MapError(
            f"map {world.name!r}: a bounding box of {area:.4g} m^2, more than the "
            f"{MAX_PLAN_AREA:.4g} m^2 the sub-goal table works on (its memory grows with the "
            "area); use a smaller map"
        )


def planning_note(world: WorldMap) -> str | None:
    """One line saying that preparing ``world`` for the planner and the sub-goal table will
    take more than a second (an estimate from the corners and the area, fitted to the
    planner's CPU times on the benchmark floors, its grid bound included: 0.14 s at 642
    corners, 0.75 s at 1,966, 1.3 s at 2,742, 3 s at 5,230; ``benchmarks/bench_big_maps.py``;
    the grid's cells, and so its time, stop growing at 20,000 m^2), else None."""
    corners, area = _corners_and_area(world)
    seconds = 0.1 * (corners / 1000) ** 2 + min(area, 20_000.0) / 15_000
    if seconds <= 1.0:
        return None
    return (
        f"map {world.name!r}: {corners} wall corners, {area:.4g} m^2; preparing its sub-goals "
        f"and paths takes about {seconds:.0f} s"
    )


def reaches_goal(world: WorldMap, start: tuple[float, float] | None = None) -> bool:
    """Whether the robot's body can get from ``start`` (default: the map's start) into the goal
    disc: the free area shrunk by the body radius around every wall (boundary inward, obstacles
    and thin walls outward) is cut into pieces; the start's piece must come closer to the goal
    than its radius."""
    x, y = (world.start.x, world.start.y) if start is None else start
    goal = world.goal
    grown = [Polygon(p).buffer(BODY_RADIUS) for p in world.obstacles]
    grown += [
        LineString([(a, b), (c, d)]).buffer(BODY_RADIUS) for a, b, c, d in world.extra_segments
    ]
    room = Polygon(world.boundary).buffer(-BODY_RADIUS)
    if grown:
        room = room.difference(unary_union(grown))
    if room.is_empty:
        return False
    here = Point(x, y)
    piece = min(getattr(room, "geoms", [room]), key=here.distance)
    return bool(piece.distance(Point(goal.x, goal.y)) < goal.radius)
