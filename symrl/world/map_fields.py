"""Readers of a map document's fields: numbers, points, polygons, thin walls, poses and the goal.

Each reader returns the field's value or raises :class:`MapError` naming the field and the
offending value, never a bare ``TypeError`` from deep inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.validation import explain_validity

__all__ = [
    "MAX_COORD",
    "MIN_GOAL_RADIUS",
    "Goal",
    "MapError",
    "Pose",
    "read_goal",
    "read_number",
    "read_point",
    "read_polygon",
    "read_pose",
    "read_segments",
    "read_starts",
    "short_repr",
]

MAX_COORD = 1e4
"""Largest magnitude (metres, radians) a map number may have: beyond it a value is a typo."""
MIN_GOAL_RADIUS = 0.1
"""Smallest goal radius (m): half the robot's step, so a path through the goal meets it."""


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


def read_number(value: Any, field_name: str) -> float:
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


def read_point(value: Any, field_name: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2:
        raise MapError(f"field {field_name!r} must be a point [x, y], got {value!r}")
    return read_number(value[0], f"{field_name}[0]"), read_number(value[1], f"{field_name}[1]")


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr`` cut to one short line, so a 3000-point polygon does not flood the message."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def read_polygon(value: Any, field_name: str) -> np.ndarray:
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) < 3:
        raise MapError(
            f"field {field_name!r} must be a polygon of at least 3 points, got {short_repr(value)}"
        )
    pts = np.array([read_point(p, f"{field_name}[{i}]") for i, p in enumerate(value)])
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
        raise MapError(f"field {field_name!r}: the polygon has zero area: {short_repr(value)}")
    return pts


def read_segments(value: Any) -> np.ndarray:
    if not isinstance(value, list):
        raise MapError(f"field 'segments' must be a list of [[x0, y0], [x1, y1]], got {value!r}")
    out = []
    for i, seg in enumerate(value):
        if not isinstance(seg, (list, tuple)) or len(seg) != 2:
            raise MapError(f"field 'segments[{i}]' must be [[x0, y0], [x1, y1]], got {seg!r}")
        a = read_point(seg[0], f"segments[{i}][0]")
        b = read_point(seg[1], f"segments[{i}][1]")
        if a == b:
            raise MapError(f"field 'segments[{i}]' has zero length: {seg!r}")
        out.append((*a, *b))
    return np.array(out, dtype=np.float64).reshape(-1, 4)


def read_pose(value: Any) -> Pose:
    if not isinstance(value, dict) or not {"x", "y"} <= set(value):
        raise MapError(f"field 'start' must be a mapping {{x, y, heading}}, got {value!r}")
    extra = set(value) - {"x", "y", "heading"}
    if extra:
        raise MapError(f"field 'start' has unknown key(s) {sorted(extra)}")
    return Pose(
        read_number(value["x"], "start.x"),
        read_number(value["y"], "start.y"),
        _read_heading(value.get("heading", 0.0), "start.heading"),
    )


def _read_heading(value: Any, field_name: str) -> float:
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


def read_starts(value: Any) -> tuple[Pose, ...]:
    """``starts:``, a list of ``[x, y, heading_deg]`` (heading in degrees, optional: 0)."""
    if not isinstance(value, list):
        raise MapError(f"field 'starts' must be a list of [x, y, heading_deg], got {value!r}")
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, (list, tuple)) or len(item) not in (2, 3):
            raise MapError(f"field 'starts[{i}]' must be [x, y, heading_deg], got {item!r}")
        x = read_number(item[0], f"starts[{i}].x")
        y = read_number(item[1], f"starts[{i}].y")
        deg = read_number(item[2], f"starts[{i}].heading_deg") if len(item) == 3 else 0.0
        if abs(deg) > 360:
            raise MapError(
                f"field 'starts[{i}].heading_deg': {item[2]!r} is outside +-360 (degrees)"
            )
        out.append(Pose(x, y, math.radians(deg)))
    return tuple(out)


def read_goal(value: Any) -> Goal:
    if not isinstance(value, dict) or not {"x", "y", "radius"} <= set(value):
        raise MapError(f"field 'goal' must be a mapping {{x, y, radius}}, got {value!r}")
    extra = set(value) - {"x", "y", "radius"}
    if extra:
        raise MapError(f"field 'goal' has unknown key(s) {sorted(extra)}")
    radius = read_number(value["radius"], "goal.radius")
    if radius <= 0:
        raise MapError(f"field 'goal.radius' must be positive, got {radius!r}")
    if radius < MIN_GOAL_RADIUS:
        raise MapError(
            f"field 'goal.radius': {radius!r} m is below {MIN_GOAL_RADIUS:g} m, half the robot's "
            "0.20 m step: its centre could pass the goal every trial without ever being that "
            "near it"
        )
    return Goal(read_number(value["x"], "goal.x"), read_number(value["y"], "goal.y"), radius)
