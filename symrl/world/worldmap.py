"""The world as data: load, validate and hold a map file (walls, start, goal, region rules).

A map is a YAML file (see ``maps/hailu2001.yaml``). Everything the simulator, the region
mapper and the planner need about the world comes from here, so a user can swap in another
world without touching code. Every fault in a map file raises :class:`MapError` naming the
field and the offending value, never a bare ``TypeError`` from deep inside.

Besides its form, a map is checked for meaning: the robot's body fits at the start and can reach
the goal, obstacles lie inside the boundary, every region line crosses the map and every region
rule can fire. Those whole-map checks use shapely (GEOS): exact, and fast on big polygons. The
per-step ray casting of the simulator stays in ``geometry.py``, which is about 13x faster than
shapely for its one query (many rays against few walls, batched in numpy).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import yaml
from shapely.geometry import LineString, MultiLineString, Point, Polygon, box
from shapely.ops import unary_union
from shapely.validation import explain_validity

from symrl.world.autoregions import auto_regions
from symrl.world.occupancy import OccupancyError, read_occupancy, trace_world

__all__ = [
    "MapError",
    "Pose",
    "Goal",
    "Condition",
    "RegionRule",
    "RegionSpec",
    "WorldMap",
    "load_map",
    "builtin_maps",
    "reaches_goal",
    "check_plannable",
    "planning_note",
    "MAX_PLAN_CORNERS",
    "MAX_PLAN_AREA",
]

YAML_LOADER: type = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""PyYAML's safe loader, on libyaml where PyYAML was built with it (the wheels are): the
pure-Python parser took most of a map's load, about 8 ms of a study worker's start."""


class _UniqueKeyLoader(YAML_LOADER):  # type: ignore[misc,valid-type]
    """The safe loader, refusing a key given twice in one mapping (PyYAML keeps the last)."""


def _no_duplicate_keys(loader: Any, node: yaml.MappingNode, deep: bool = False) -> Any:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _no_duplicate_keys)

MAX_PLAN_CORNERS = 1000
"""Most wall corners (polygon vertices, two per thin wall) a map the planner and the sub-goal
table work on may have: their time grows faster than the corners (the planner, asking only the
walls near each query: a 30 m x 50 m office floor of 400 corners about 5.5 s, 640 about 15 s,
``benchmarks/bench_big_maps.py``): a building floor of up to a thousand corners is prepared in
a minute or so, not hours."""
MAX_PLAN_AREA = 250_000.0
"""Largest bounding box (m^2) of a map the sub-goal table works on: its look-out grid (one
point per 0.2 m) grows with the area (a 400 m square: 1 s and 0.5 GB; 2 km: 32 s and 3.5 GB)."""

_COND = re.compile(r"^\s*([xy])\s*([<>])\s*([A-Za-z_][A-Za-z0-9_]*)\s*$")
_TOP_KEYS = {
    "name",
    "boundary",
    "obstacles",
    "segments",
    "start",
    "goal",
    "regions",
    "starts",
    "occupancy",
}
_DRAWN_KEYS = ("boundary", "obstacles", "segments")
_SHAPELY_FROM = 200
"""Polygon corners from which :meth:`WorldMap.in_free_area` asks GEOS (the even-odd loop below
costs a Python iteration per edge: 0.15 s a call on 3,000 corners)."""
MAX_COORD = 1e4
"""Largest magnitude (metres, radians) a map number may have: beyond it a value is a typo."""
BODY_RADIUS = 0.26
"""The B21's body radius (metres): the start must be this far from every wall and the goal
reachable by a disc this size. ``RobotConfig.radius`` has the same default."""


class MapError(ValueError):
    """A map file or map dict is malformed; the message names the field and the value."""


@dataclass(frozen=True)
class Pose:
    x: float
    y: float
    heading: float = 0.0


@dataclass(frozen=True)
class Goal:
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Condition:
    """``axis op line``: e.g. ``x > l3`` is axis 0, sign +1, the x-intercept of l3."""

    axis: int  # 0 for x, 1 for y
    greater: bool  # True for ">", False for "<"
    threshold: float
    text: str


@dataclass(frozen=True)
class RegionRule:
    region: str
    conditions: tuple[Condition, ...]

    def bounds(self, world_bounds: tuple[float, float, float, float]) -> list[list[float]]:
        """The axis-aligned box ``[[x_lo, x_hi], [y_lo, y_hi]]`` its conditions allow inside the
        map's bounds widened by 1 m (empty when a lower end is not below its upper end)."""
        xmin, xmax, ymin, ymax = world_bounds
        lo_hi = [[xmin - 1.0, xmax + 1.0], [ymin - 1.0, ymax + 1.0]]
        for c in self.conditions:
            bound = lo_hi[c.axis]
            if c.greater:
                bound[0] = max(bound[0], c.threshold)
            else:
                bound[1] = min(bound[1], c.threshold)
        return lo_hi


@dataclass(frozen=True)
class RegionSpec:
    """The symbolic partition (paper section 6.1): named lines and first-match rules."""

    names: tuple[str, ...]
    lines: dict[str, tuple[str, float]]  # name -> ("x" | "y", intercept)
    rules: tuple[RegionRule, ...]

    def region_of(self, x: float, y: float) -> str:
        """Reference implementation of the rules for one point (the torch module batches
        this)."""
        return self.regions_of(np.array([x], dtype=np.float64), np.array([y], dtype=np.float64))[0]

    def regions_of(self, x: np.ndarray, y: np.ndarray) -> list[str]:
        """The region of many points (float64 arrays of one shape, flattened): first-match
        rules, each rule's strict comparisons on all points at once (thousands of points when
        the sub-goal table scans the region lines)."""
        xy = (np.asarray(x, dtype=np.float64).ravel(), np.asarray(y, dtype=np.float64).ravel())
        found = np.full(len(xy[0]), -1)
        for i, rule in enumerate(self.rules):
            holds = found < 0
            for c in rule.conditions:
                v = xy[c.axis]
                holds &= v > c.threshold if c.greater else v < c.threshold
            found[holds] = i
        if (found < 0).any():
            j = int(np.argmax(found < 0))
            raise MapError(
                f"regions.rules: no rule matches the pose ({float(xy[0][j])}, {float(xy[1][j])}); "
                "add a default rule"
            )
        return [self.rules[i].region for i in found.tolist()]


@dataclass(frozen=True)
class WorldMap:
    """A validated world. Walls are all given as segments ``(n, 4)``: x0, y0, x1, y1."""

    name: str
    boundary: np.ndarray  # (k, 2) free-area polygon
    obstacles: tuple[np.ndarray, ...]  # solid polygons inside the free area
    extra_segments: np.ndarray  # (m, 4) thin walls
    start: Pose
    goal: Goal
    regions: RegionSpec
    source: str = field(default="<dict>")
    starts: tuple[Pose, ...] = ()
    """Optional extra start poses (the map's ``starts:``) for driving a learned controller from
    elsewhere; empty: the studies derive some from the walls."""

    @property
    def segments(self) -> np.ndarray:
        """Every wall as one ``(n, 4)`` float64 array (boundary edges, obstacle edges, segments)."""
        parts = [_edges(self.boundary)] + [_edges(p) for p in self.obstacles]
        parts.append(self.extra_segments.reshape(-1, 4))
        return np.concatenate(parts, axis=0)

    def in_free_area(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """True where the point is inside the boundary and outside every obstacle."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        if len(self.boundary) + sum(len(p) for p in self.obstacles) > _SHAPELY_FROM:
            return np.asarray(shapely.intersects_xy(self.free_polygon, x, y))  # GEOS, indexed
        inside = _point_in_polygon(x, y, self.boundary)
        for poly in self.obstacles:
            inside &= ~_point_in_polygon(x, y, poly)
        return inside

    @cached_property
    def free_polygon(self) -> Polygon:
        """The free area as one shapely geometry (boundary minus obstacles), prepared for fast
        ``shapely.contains_xy`` queries; thin walls have no area and are not in it."""
        geom = Polygon(self.boundary)
        if self.obstacles:
            geom = geom.difference(unary_union([Polygon(p) for p in self.obstacles]))
        shapely.prepare(geom)
        return geom

    def contains_xy(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """True where the point is strictly inside the free area (shapely, vectorised); the
        same as :meth:`in_free_area` except on the walls themselves."""
        return shapely.contains_xy(self.free_polygon, x, y)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the boundary polygon."""
        b = self.boundary
        return (
            float(b[:, 0].min()),
            float(b[:, 0].max()),
            float(b[:, 1].min()),
            float(b[:, 1].max()),
        )

    def with_obstacle(self, polygon: list[list[float]] | np.ndarray) -> WorldMap:
        """A copy of this map with one more solid polygon (for the new-obstacle study)."""
        poly = _polygon(polygon, f"obstacles[{len(self.obstacles)}]")
        return WorldMap(
            self.name + "+obstacle",
            self.boundary,
            self.obstacles + (poly,),
            self.extra_segments,
            self.start,
            self.goal,
            self.regions,
            self.source,
            self.starts,
        )


def builtin_maps() -> list[str]:
    """Names of the maps shipped with symrl."""
    folder = resources.files("symrl.world") / "maps"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


SUITES = ("tuning", "check")
"""Named suites of benchmark worlds shipped beside the maps (``maps/<suite>/``): ``tuning``, the
worlds the map rung's route was tuned on; ``check``, worlds written to check it, never tuned on.
``load_map("tuning/long_wall")`` and ``--map tuning/long_wall`` take a suite's world."""


def suite_maps(suite: str) -> list[str]:
    """Names (``suite/world``) of the worlds of a shipped suite."""
    if suite not in SUITES:
        raise MapError(f"suite {suite!r}: unknown; the suites are {', '.join(SUITES)}")
    folder = resources.files("symrl.world") / "maps" / suite
    return sorted(f"{suite}/{p.name[:-5]}" for p in folder.iterdir() if p.name.endswith(".yaml"))


def _shipped(name: str) -> bool:
    """A built-in map's name, or a suite's world's (``suite/world``)."""
    suite, _, _ = name.rpartition("/")
    if suite:
        return suite in SUITES and name in suite_maps(suite)
    return name in builtin_maps()


def load_map(source: str | Path | dict[str, Any] = "hailu2001") -> WorldMap:
    """Load a map by built-in name, file path, or an already-parsed dict, and validate it."""
    if isinstance(source, dict):
        return parse_map(source, "<dict>")
    text_source = str(source)
    path = Path(text_source)
    if not path.suffix and not path.exists():
        if not _shipped(text_source):
            raise MapError(
                f"map {text_source!r}: not a file and not a built-in map "
                f"(built-in: {', '.join(builtin_maps())}; suites: "
                + ", ".join(f"{s}/NAME" for s in SUITES)
                + ")"
            )
        path = Path(str(resources.files("symrl.world") / "maps" / f"{text_source}.yaml"))
    if not path.exists():
        raise MapError(f"map file {str(path)!r} does not exist")
    if path.is_dir():
        raise MapError(f"map file {str(path)!r} is a directory, not a map file")
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise MapError(f"map file {str(path)!r} cannot be read: {err.strerror}") from None
    if b"\0" in raw:
        raise MapError(f"map file {str(path)!r} is a binary file, not a YAML map")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise MapError(
            f"map file {str(path)!r} is not UTF-8 text (byte {err.start}: {raw[err.start]:#04x})"
        ) from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as err:
        reason = " ".join(str(err).split())
        raise MapError(f"map file {str(path)!r} is not valid YAML: {reason}") from None
    return parse_map(data, str(path))


def parse_map(data: Any, source: str = "<dict>") -> WorldMap:
    """Validate a parsed map document and build a :class:`WorldMap`."""
    if not isinstance(data, dict):
        raise MapError(f"{source}: a map must be a mapping of fields, got {type(data).__name__}")
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise MapError(
            f"{source}: unknown field(s) {sorted(unknown)}; allowed: {sorted(_TOP_KEYS)}"
        )
    if "occupancy" in data:
        data = _with_traced_walls(data, source)
    for key in ("boundary", "start", "goal"):
        if key not in data:
            raise MapError(f"{source}: missing required field {key!r}")
    name = data.get("name", Path(source).stem)
    if not isinstance(name, str) or not name:
        raise MapError(f"{source}: field 'name' must be a non-empty string, got {name!r}")

    boundary = _polygon(data["boundary"], "boundary")
    obstacles_raw = data.get("obstacles") or []
    if not isinstance(obstacles_raw, list):
        raise MapError(f"field 'obstacles' must be a list of polygons, got {obstacles_raw!r}")
    obstacles = tuple(_polygon(p, f"obstacles[{i}]") for i, p in enumerate(obstacles_raw))
    segments = _segments(data.get("segments") or [])
    start = _pose(data["start"])
    starts = _starts(data.get("starts") or [])
    goal = _goal(data["goal"])
    regions_raw = data.get("regions", "auto")
    _check_room(boundary)
    if regions_raw == "auto":  # no hand-written rules: find rooms and doors from the walls
        _check_auto_size(boundary, obstacles, segments)
        regions_raw = auto_regions(boundary, obstacles, segments)
    regions = _regions(regions_raw)

    world = WorldMap(name, boundary, obstacles, segments, start, goal, regions, source, starts)
    points = [("start", (start.x, start.y)), ("goal", (goal.x, goal.y))]
    points += [(f"starts[{i}]", (p.x, p.y)) for i, p in enumerate(starts)]
    for label, (px, py) in points:
        if not bool(world.in_free_area(px, py)):
            raise MapError(f"field {label!r}: the point ({px}, {py}) is not in the free area")
    _check_meaning(world, source)
    return world


def _with_traced_walls(data: dict[str, Any], source: str) -> dict[str, Any]:
    """The map document with ``occupancy: PATH`` (a map_server YAML, relative to the map file)
    replaced by the walls traced from it (:mod:`symrl.world.occupancy`)."""
    drawn = [k for k in _DRAWN_KEYS if k in data]
    if drawn:
        raise MapError(
            f"{source}: field 'occupancy' takes the place of {drawn}; give one or the other"
        )
    ref = data["occupancy"]
    if not isinstance(ref, str) or not ref:
        raise MapError(
            f"{source}: field 'occupancy' must be a path to a map_server YAML, got {ref!r}"
        )
    path = Path(ref)
    if not path.is_absolute() and source != "<dict>":
        path = Path(source).parent / path
    for key in ("start", "goal"):
        if key not in data:
            raise MapError(f"{source}: missing required field {key!r}")
    start, goal = _pose(data["start"]), _goal(data["goal"])
    try:
        boundary, holes = trace_world(
            read_occupancy(path), (start.x, start.y), (goal.x, goal.y), source
        )
    except OccupancyError as err:
        raise MapError(str(err)) from None
    rest = {k: v for k, v in data.items() if k != "occupancy"}
    return rest | {"boundary": boundary.tolist(), "obstacles": [h.tolist() for h in holes]}


# --- field validators -------------------------------------------------------------------


MAX_AUTO_PIECES = 100
"""Most obstacles plus segments a map may have when its regions are found from the walls
(``regions: auto``): the search grows with their square (100: a few seconds)."""
MAX_AUTO_CORNERS = 20_000
"""Most polygon corners a map may have when its regions are found from the walls."""


def _check_room(boundary: np.ndarray) -> None:
    """The free area must hold the robot's body, before anything is computed in it."""
    width, height = (float(v) for v in np.ptp(boundary, axis=0))
    if min(width, height) < 2 * BODY_RADIUS:
        raise MapError(
            f"field 'boundary': the room spans only {width:.3g} x {height:.3g} m; the robot's body "
            f"(radius {BODY_RADIUS} m) does not fit in it"
        )


def _check_auto_size(
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


MAX_REGIONS = 64
"""Most regions a map may name (the shipped maps name at most 7)."""
MIN_GOAL_RADIUS = 0.1
"""Smallest goal radius (m): half the robot's step, so a path through the goal meets it."""


def _number(value: Any, field_name: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        raise MapError(f"field {field_name!r} must be a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise MapError(f"field {field_name!r} must be finite, got {value!r}")
    if abs(number) > MAX_COORD:
        raise MapError(
            f"field {field_name!r}: {value!r} is absurdly large (a map spans at most "
            f"|value| <= {MAX_COORD:g} m)"
        )
    return number


def _point(value: Any, field_name: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2:
        raise MapError(f"field {field_name!r} must be a point [x, y], got {value!r}")
    return _number(value[0], f"{field_name}[0]"), _number(value[1], f"{field_name}[1]")


def _show(value: Any, limit: int = 80) -> str:
    """``repr`` cut to one short line, so a 3000-point polygon does not flood the message."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _polygon(value: Any, field_name: str) -> np.ndarray:
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) < 3:
        raise MapError(
            f"field {field_name!r} must be a polygon of at least 3 points, got {_show(value)}"
        )
    pts = np.array([_point(p, f"{field_name}[{i}]") for i, p in enumerate(value)])
    if len(pts) > 3 and np.array_equal(pts[0], pts[-1]):
        pts = pts[:-1]  # a closed ring (first point repeated) means the same polygon
    repeated = np.all(pts == np.roll(pts, -1, axis=0), axis=1)
    if repeated.any():
        i = int(np.argmax(repeated))
        raise MapError(
            f"field {field_name!r}: points {i} and {(i + 1) % len(pts)} coincide "
            f"({pts[i].tolist()}), which makes a zero-length wall"
        )
    # GEOS instead of the all-pairs edge test: O(n log n), 3000 points in milliseconds
    centred = pts - pts.mean(axis=0)
    collinear = np.linalg.matrix_rank(centred, tol=1e-9) < 2
    if not collinear and not shapely.LinearRing(pts).is_simple:
        reason = explain_validity(Polygon(pts))
        raise MapError(
            f"field {field_name!r}: the polygon crosses itself or touches itself ({reason})"
        )
    area = 0.5 * float(
        np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
    )
    if collinear or abs(area) < 1e-12:
        raise MapError(f"field {field_name!r}: the polygon has zero area: {_show(value)}")
    return pts


def _segments(value: Any) -> np.ndarray:
    if not isinstance(value, list):
        raise MapError(f"field 'segments' must be a list of [[x0, y0], [x1, y1]], got {value!r}")
    out = []
    for i, seg in enumerate(value):
        if not isinstance(seg, (list, tuple)) or len(seg) != 2:
            raise MapError(f"field 'segments[{i}]' must be [[x0, y0], [x1, y1]], got {seg!r}")
        a = _point(seg[0], f"segments[{i}][0]")
        b = _point(seg[1], f"segments[{i}][1]")
        if a == b:
            raise MapError(f"field 'segments[{i}]' has zero length: {seg!r}")
        out.append((*a, *b))
    return np.array(out, dtype=np.float64).reshape(-1, 4)


def _pose(value: Any) -> Pose:
    if not isinstance(value, dict) or not {"x", "y"} <= set(value):
        raise MapError(f"field 'start' must be a mapping {{x, y, heading}}, got {value!r}")
    extra = set(value) - {"x", "y", "heading"}
    if extra:
        raise MapError(f"field 'start' has unknown key(s) {sorted(extra)}")
    return Pose(
        _number(value["x"], "start.x"),
        _number(value["y"], "start.y"),
        _heading(value.get("heading", 0.0), "start.heading"),
    )


def _heading(value: Any, field_name: str) -> float:
    """A start heading in radians, within +-2 pi: a larger one is almost surely degrees."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        raise MapError(f"field {field_name!r} must be a number (radians), got {value!r}")
    number = float(value)
    if not math.isfinite(number) or abs(number) > 2 * math.pi:
        raise MapError(
            f"field {field_name!r}: {value!r} is outside +-2*pi; a map's start heading is in "
            f"radians (e.g. 90 degrees is 1.5708), not degrees"
        )
    return number


def _starts(value: Any) -> tuple[Pose, ...]:
    """``starts:``, a list of ``[x, y, heading_deg]`` (heading in degrees, optional: 0)."""
    if not isinstance(value, list):
        raise MapError(f"field 'starts' must be a list of [x, y, heading_deg], got {value!r}")
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, (list, tuple)) or len(item) not in (2, 3):
            raise MapError(f"field 'starts[{i}]' must be [x, y, heading_deg], got {item!r}")
        x = _number(item[0], f"starts[{i}].x")
        y = _number(item[1], f"starts[{i}].y")
        deg = _number(item[2], f"starts[{i}].heading_deg") if len(item) == 3 else 0.0
        if abs(deg) > 360:
            raise MapError(
                f"field 'starts[{i}].heading_deg': {item[2]!r} is outside +-360 (degrees)"
            )
        out.append(Pose(x, y, math.radians(deg)))
    return tuple(out)


def _goal(value: Any) -> Goal:
    if not isinstance(value, dict) or not {"x", "y", "radius"} <= set(value):
        raise MapError(f"field 'goal' must be a mapping {{x, y, radius}}, got {value!r}")
    extra = set(value) - {"x", "y", "radius"}
    if extra:
        raise MapError(f"field 'goal' has unknown key(s) {sorted(extra)}")
    radius = _number(value["radius"], "goal.radius")
    if radius <= 0:
        raise MapError(f"field 'goal.radius' must be positive, got {radius!r}")
    if radius < MIN_GOAL_RADIUS:
        raise MapError(
            f"field 'goal.radius': {radius!r} m is below {MIN_GOAL_RADIUS:g} m, half the robot's "
            "0.20 m step: its centre could pass the goal every trial without ever being that "
            "near it"
        )
    return Goal(_number(value["x"], "goal.x"), _number(value["y"], "goal.y"), radius)


def _regions(value: Any) -> RegionSpec:
    if not isinstance(value, dict):
        raise MapError(
            "field 'regions' must be 'auto' or a mapping {names, lines, rules}, "
            f"got {_show(value)}"
        )
    for key in ("names", "lines", "rules"):
        if key not in value:
            raise MapError(f"field 'regions' is missing {key!r}")
    extra = set(value) - {"names", "lines", "rules"}
    if extra:
        raise MapError(f"field 'regions' has unknown key(s) {sorted(extra)}")
    names = value["names"]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise MapError(f"field 'regions.names' must be a non-empty list of strings, got {names!r}")
    if len(set(names)) != len(names):
        raise MapError(f"field 'regions.names' has duplicates: {names!r}")
    if len(names) > MAX_REGIONS:  # before the rules are checked over the map
        raise MapError(
            f"field 'regions.names': {len(names)} regions, more than {MAX_REGIONS} (the learner "
            "keeps an expert and an option critic per region)"
        )

    lines_raw = value["lines"]
    if not isinstance(lines_raw, dict):
        raise MapError("field 'regions.lines' must be a mapping name -> {x: .} or {y: .}")
    lines: dict[str, tuple[str, float]] = {}
    for lname, spec in lines_raw.items():
        if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in ("x", "y"):
            raise MapError(
                f"field 'regions.lines.{lname}' must be {{x: value}} or {{y: value}}, got {spec!r}"
            )
        axis, intercept = next(iter(spec.items()))
        lines[str(lname)] = (axis, _number(intercept, f"regions.lines.{lname}.{axis}"))

    rules_raw = value["rules"]
    if not isinstance(rules_raw, list) or not rules_raw:
        raise MapError(f"field 'regions.rules' must be a non-empty list, got {rules_raw!r}")
    rules = []
    for i, rule in enumerate(rules_raw):
        where = f"regions.rules[{i}]"
        if not isinstance(rule, dict) or "region" not in rule:
            raise MapError(f"field {where!r} must be a mapping with 'region', got {rule!r}")
        extra = set(rule) - {"region", "when"}
        if extra:
            raise MapError(f"field {where!r} has unknown key(s) {sorted(extra)}")
        if rule["region"] not in names:
            raise MapError(
                f"field '{where}.region': unknown region {rule['region']!r} (names: {names})"
            )
        when = rule.get("when", [])
        if not isinstance(when, list):
            raise MapError(f"field '{where}.when' must be a list of conditions, got {when!r}")
        conds = []
        for j, text in enumerate(when):
            m = _COND.match(text) if isinstance(text, str) else None
            if m is None:
                raise MapError(
                    f"field '{where}.when[{j}]': cannot read condition {text!r} "
                    "(expected e.g. 'x > l3' or 'y < l1')"
                )
            axis, op, lname = m.groups()
            if lname not in lines:
                raise MapError(f"field '{where}.when[{j}]': unknown line {lname!r} in {text!r}")
            line_axis, intercept = lines[lname]
            if line_axis != axis:
                raise MapError(
                    f"field '{where}.when[{j}]': {text!r} compares {axis} with line {lname!r}, "
                    f"which is a {line_axis}-line"
                )
            conds.append(Condition(0 if axis == "x" else 1, op == ">", intercept, text))
        rules.append(RegionRule(rule["region"], tuple(conds)))
    if rules[-1].conditions:
        raise MapError(
            "field 'regions.rules': the last rule must be a default (no 'when'), "
            f"got {rules_raw[-1]!r}"
        )
    unreachable = [n for n in names if n not in {r.region for r in rules}]
    if unreachable:
        raise MapError(f"field 'regions.names': region(s) {unreachable} have no rule")
    return RegionSpec(tuple(names), lines, tuple(rules))


# --- checks for meaning (shapely) ----------------------------------------------------------


def _check_meaning(world: WorldMap, source: str) -> None:
    """Faults a well-formed map can still have: things a robot or the region rules cannot do."""
    where = f"{source}: field"
    outer = Polygon(world.boundary)
    for i, poly in enumerate(world.obstacles):
        if not outer.covers(Polygon(poly)):
            raise MapError(
                f"{where} 'obstacles[{i}]': the polygon {_show(poly.tolist())} is not inside "
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
    _check_regions(world, source, outer)


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
            "planner and the sub-goal table work on (their time grows with its square); "
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
    take more than a second (an estimate from the corners and the area), else None."""
    corners, area = _corners_and_area(world)
    seconds = 3.5 * (corners / 200) ** 2 + area / 160_000
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


def _check_regions(world: WorldMap, source: str, outer: Polygon) -> None:
    """Every region line crosses the map, and every rule owns some free area."""
    xmin, xmax, ymin, ymax = world.bounds
    for name, (axis, value) in world.regions.lines.items():
        lo, hi = (xmin, xmax) if axis == "x" else (ymin, ymax)
        if not lo < value < hi:
            raise MapError(
                f"{source}: field 'regions.lines.{name}': {axis} = {value} lies outside the map "
                f"({axis} from {lo} to {hi})"
            )
    free = world.free_polygon
    taken = None
    for i, rule in enumerate(world.regions.rules):
        lo_hi = rule.bounds(world.bounds)
        cell = box(lo_hi[0][0], lo_hi[1][0], lo_hi[0][1], lo_hi[1][1])
        if any(lo >= hi for lo, hi in lo_hi) or free.intersection(cell).area <= 1e-9:
            raise MapError(
                f"{source}: field 'regions.rules[{i}]' (region {rule.region!r}, when "
                f"{[c.text for c in rule.conditions]}) can never fire: it matches no free point"
            )
        fires = cell if taken is None else cell.difference(taken)
        if free.intersection(fires).area <= 1e-9:
            raise MapError(
                f"{source}: field 'regions.rules[{i}]' (region {rule.region!r}, when "
                f"{[c.text for c in rule.conditions]}) can never fire: earlier rules match "
                "every free point it matches"
            )
        taken = cell if taken is None else taken.union(cell)


# --- small geometry helpers (validation only; the simulator has its own vectorised ones) ----


def _edges(poly: np.ndarray) -> np.ndarray:
    return np.concatenate([poly, np.roll(poly, -1, axis=0)], axis=1)


def _point_in_polygon(x: np.ndarray, y: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorised over points."""
    inside = np.zeros(np.broadcast(x, y).shape, dtype=bool)
    x0, y0 = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    for ax, ay, bx, by in zip(x0, y0, x1, y1, strict=True):
        crosses = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = ax + (y - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (x < xint)
    return inside
