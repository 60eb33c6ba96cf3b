"""The validated world: :class:`WorldMap`, a map's walls as segments, free area and bounds."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.ops import unary_union

from symrl.world.map_fields import Goal, Pose, read_polygon
from symrl.world.map_regions import RegionSpec

__all__ = ["WorldMap"]

_SHAPELY_FROM = 200
"""Polygon corners from which :meth:`WorldMap.in_free_area` asks GEOS (the even-odd loop below
costs a Python iteration per edge: 0.15 s a call on 3,000 corners)."""


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
        poly = read_polygon(polygon, f"obstacles[{len(self.obstacles)}]")
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
