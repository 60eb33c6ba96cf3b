"""The world as data: load and validate a map file (walls, start, goal, region rules).

A map is a YAML file (see ``maps/hailu2001.yaml``). Everything the simulator, the region
mapper and the planner need about the world comes from here, so a user can swap in another
world without touching code. Every fault in a map file raises :class:`MapError` naming the
field and the offending value, never a bare ``TypeError`` from deep inside.

Besides its form, a map is checked for meaning: the robot's body fits at the start and can reach
the goal, obstacles lie inside the boundary, every region line crosses the map and every region
rule can fire. Those whole-map checks use shapely (GEOS): exact, and fast on big polygons. The
per-step ray casting of the simulator stays in ``geometry.py``, which is about 13x faster than
shapely for its one query (many rays against few walls, batched in numpy).

This module reads the file and puts the map together; the parts live by job, and their public
names are all importable from here: the field readers (:mod:`symrl.world.map_fields`), the
region rules (:mod:`symrl.world.map_regions`), :class:`WorldMap` (:mod:`symrl.world.map_model`)
and the checks for meaning (:mod:`symrl.world.map_checks`).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from symrl.world.autoregions import auto_regions
from symrl.world.map_checks import (
    BODY_RADIUS,
    MAX_AUTO_CORNERS,
    MAX_AUTO_PIECES,
    MAX_PLAN_AREA,
    MAX_PLAN_CORNERS,
    check_auto_size,
    check_meaning,
    check_plannable,
    check_room,
    planning_note,
    reaches_goal,
)
from symrl.world.map_fields import (
    MAX_COORD,
    MIN_GOAL_RADIUS,
    Goal,
    MapError,
    Pose,
    read_goal,
    read_polygon,
    read_pose,
    read_segments,
    read_starts,
)
from symrl.world.map_model import WorldMap
from symrl.world.map_regions import MAX_REGIONS, Condition, RegionRule, RegionSpec, read_regions
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
    "parse_map",
    "builtin_maps",
    "suite_maps",
    "SUITES",
    "reaches_goal",
    "check_plannable",
    "planning_note",
    "BODY_RADIUS",
    "MAX_AUTO_CORNERS",
    "MAX_AUTO_PIECES",
    "MAX_COORD",
    "MAX_PLAN_CORNERS",
    "MAX_PLAN_AREA",
    "MAX_REGIONS",
    "MIN_GOAL_RADIUS",
    "YAML_LOADER",
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

    boundary = read_polygon(data["boundary"], "boundary")
    obstacles_raw = data.get("obstacles") or []
    if not isinstance(obstacles_raw, list):
        raise MapError(f"field 'obstacles' must be a list of polygons, got {obstacles_raw!r}")
    obstacles = tuple(read_polygon(p, f"obstacles[{i}]") for i, p in enumerate(obstacles_raw))
    segments = read_segments(data.get("segments") or [])
    start = read_pose(data["start"])
    starts = read_starts(data.get("starts") or [])
    goal = read_goal(data["goal"])
    regions_raw = data.get("regions", "auto")
    check_room(boundary)
    if regions_raw == "auto":  # no hand-written rules: find rooms and doors from the walls
        check_auto_size(boundary, obstacles, segments)
        regions_raw = auto_regions(boundary, obstacles, segments)
    regions = read_regions(regions_raw)

    world = WorldMap(name, boundary, obstacles, segments, start, goal, regions, source, starts)
    points = [("start", (start.x, start.y)), ("goal", (goal.x, goal.y))]
    points += [(f"starts[{i}]", (p.x, p.y)) for i, p in enumerate(starts)]
    for label, (px, py) in points:
        if not bool(world.in_free_area(px, py)):
            raise MapError(f"field {label!r}: the point ({px}, {py}) is not in the free area")
    check_meaning(world, source)
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
    start, goal = read_pose(data["start"]), read_goal(data["goal"])
    try:
        boundary, holes = trace_world(
            read_occupancy(path), (start.x, start.y), (goal.x, goal.y), source
        )
    except OccupancyError as err:
        raise MapError(str(err)) from None
    rest = {k: v for k, v in data.items() if k != "occupancy"}
    return rest | {"boundary": boundary.tolist(), "obstacles": [h.tolist() for h in holes]}
