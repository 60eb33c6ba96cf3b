"""Region rules found from the map itself (``regions: auto``, or a map without ``regions``).

A hand-written map names its rooms, doors and corridors with lines and first-match rules (paper
section 6.1). This module writes such rules from the walls alone, so any floor plan gets a
partition the region mapper and the sub-goal builder can use:

1. **Narrowings.** Every wall corner's x (and y) is a candidate vertical (horizontal) line. Where
   such a line crosses a free stretch at most ``max_door`` wide but at least the robot's width, and
   the free stretch through the same point ``probe`` metres to one side is ``widen`` times wider,
   the stretch is a door-like narrowing: a door's face, a gap in a thin wall, a corridor's mouth.
2. **Corners.** A corner where the free area is concave (its free side spans more than 180
   degrees: the inner corner of a bend, the end of a thin wall, the outer corner of a pocket) is
   where steering straight at something stops working. From each such corner, in coordinate
   order, the axis-parallel chords into the free area (up to the next wall or cut) are taken
   shortest first until every free sector left at the corner spans at most 180 degrees; chords
   as short as the last one taken (within ``tie``) are taken too, so the square where two equal
   arms meet becomes its own piece. A sharp corner (a free sector of 270 degrees or more: a
   wall's free end, the outer corner of a pocket, a U or a pillar) that would need a chord
   longer than ``sharp_cut`` (the sonar's 5 m), or a shallow one (a slight bend in a wall) that
   would need one longer than ``max_cut`` (2 m), is left whole. Each chord is a cut, and the
   corners after it see it as a wall.
3. **Regions.** The free area cut along the narrowings and chords falls into connected pieces; a
   piece of less than ``door_area`` square metres is a door (``door1``, ...), any other a room
   (``room1``, ...), numbered by their lowest, then leftmost point.
4. **Rules.** The narrowing lines cut the plane into a grid of boxes; while a box's free area
   holds pieces of two regions, the wall-corner line that leaves the fewest such boxes is added.
   Each box then becomes one rule; the region with the most boxes is the default.

Everything is ordered by coordinates, so the same map always gives the same rules.
"""

from __future__ import annotations

from itertools import product
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

from symrl.world.region_cuts import (
    AutoRegionConfig,
    corner_cuts,
    free_area,
    narrowings,
    wall_segments,
)

__all__ = ["AutoRegionConfig", "auto_regions"]

Cells = list[tuple[tuple, Any]]
"""Grid boxes ``((x_lo, x_hi, y_lo, y_hi), box)`` (see :func:`_cells`)."""


def _pieces(free, cuts: list[tuple[int, float, float, float]]) -> list:
    """Connected pieces of the free area cut along the narrowings, by lowest then leftmost."""
    slits = [
        LineString([(c, a), (c, b)] if axis == 0 else [(a, c), (b, c)]).buffer(
            1e-6, cap_style="flat"
        )
        for axis, c, a, b in cuts
    ]
    cut = free.difference(unary_union(slits)) if slits else free
    parts = [g for g in getattr(cut, "geoms", [cut]) if g.area > 1e-6]
    return sorted(parts, key=lambda g: (round(g.bounds[1], 6), round(g.bounds[0], 6)))


def _cells(lines: tuple[list[float], list[float]], bounds) -> list[tuple[tuple, Any]]:
    """The grid boxes of the x-lines and y-lines: ``((x_lo, x_hi, y_lo, y_hi), box)``, with
    infinite sides outside the lines."""
    xmin, ymin, xmax, ymax = bounds
    xs = [-np.inf, *sorted(lines[0]), np.inf]
    ys = [-np.inf, *sorted(lines[1]), np.inf]
    out = []
    for (y0, y1), (x0, x1) in product(
        zip(ys[:-1], ys[1:], strict=True), zip(xs[:-1], xs[1:], strict=True)
    ):
        geom = box(max(x0, xmin - 1), max(y0, ymin - 1), min(x1, xmax + 1), min(y1, ymax + 1))
        out.append(((x0, x1, y0, y1), geom))
    return out


def _owners(cells, pieces) -> list[list[int]]:
    """Per box, the pieces whose free area in it exceeds 1e-6 m^2, in piece order: only the
    pairs whose bounding boxes meet are intersected (an STR tree; thousands of boxes and
    hundreds of pieces on a building floor)."""
    geoms = np.array([g for _, g in cells], dtype=object)
    owners: list[list[int]] = [[] for _ in cells]
    if not len(pieces) or not len(geoms):
        return owners
    parts = np.array(pieces, dtype=object)
    box_i, piece_i = shapely.STRtree(parts).query(geoms)
    areas = shapely.area(shapely.intersection(parts[piece_i], geoms[box_i]))
    some = areas > 1e-6
    for b, i in sorted(zip(box_i[some].tolist(), piece_i[some].tolist(), strict=True)):
        owners[b].append(i)
    return owners


def _clashes(owners: list[list[int]], kinds: list[str]) -> int:
    return sum(max(0, len({kinds[i] for i in o}) - 1) for o in owners)


def auto_regions(
    boundary: np.ndarray,
    obstacles: list[np.ndarray] | tuple[np.ndarray, ...],
    segments: np.ndarray,
    config: AutoRegionConfig | None = None,
) -> dict[str, Any]:
    """A ``regions`` mapping (``names``, ``lines``, ``rules``) in the map-file format, found from
    the walls. Feed it to ``parse_map`` like a hand-written one."""
    config = config or AutoRegionConfig()
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    free = free_area(boundary, list(obstacles), segments)
    shapely.prepare(free)
    xmin, ymin, xmax, ymax = Polygon(boundary).bounds
    pts = np.concatenate([boundary, *obstacles, segments.reshape(-1, 2)])
    coords = (
        sorted({float(x) for x in pts[:, 0] if xmin < x < xmax}),
        sorted({float(y) for y in pts[:, 1] if ymin < y < ymax}),
    )
    cuts = narrowings(free, (xmin, ymin, xmax, ymax), coords, config)
    cuts += corner_cuts(free, wall_segments(boundary, list(obstacles), segments), cuts, config)
    pieces = _pieces(free, cuts)
    kinds, counters = [], {"door": 0, "room": 0}
    for p in pieces:
        kind = "door" if p.area < config.door_area else "room"
        counters[kind] += 1
        kinds.append(f"{kind}{counters[kind]}")

    lines: tuple[list[float], list[float]] = (
        sorted({c for axis, c, _, _ in cuts if axis == 0}),
        sorted({c for axis, c, _, _ in cuts if axis == 1}),
    )
    cells, owners = _separate(lines, coords, (xmin, ymin, xmax, ymax), pieces, kinds)
    return _rules(lines, cells, owners, pieces, kinds)


def _separate(
    lines: tuple[list[float], list[float]],
    coords: tuple[list[float], list[float]],
    bounds: tuple[float, float, float, float],
    pieces: list,
    kinds: list[str],
) -> tuple[Cells, list[list[int]]]:
    """Add wall-corner lines to ``lines`` (in place) while a grid box holds pieces of two
    regions, each time the one that leaves the fewest such boxes (module docstring, step 4);
    the final grid boxes and their pieces."""
    cells = _cells(lines, bounds)
    owners = _owners(cells, pieces)
    while _clashes(owners, kinds):
        best = None
        for axis in (0, 1):
            for c in coords[axis]:
                if c in lines[axis]:
                    continue
                trial = (lines[0] + [c], lines[1]) if axis == 0 else (lines[0], lines[1] + [c])
                trial_cells = _cells(trial, bounds)
                score = _clashes(_owners(trial_cells, pieces), kinds)
                if best is None or score < best[0]:
                    best = (score, axis, c)
        if best is None or best[0] >= _clashes(owners, kinds):
            break  # no corner line helps: leave the clash to the first matching rule
        lines[best[1]].append(best[2])
        cells = _cells(lines, bounds)
        owners = _owners(cells, pieces)
    return cells, owners


def _rules(
    lines: tuple[list[float], list[float]],
    cells: Cells,
    owners: list[list[int]],
    pieces: list,
    kinds: list[str],
) -> dict[str, Any]:
    """The ``regions`` mapping: one rule per grid box with free area, the region with the most
    boxes as the default."""
    names_x = {c: f"x{i + 1}" for i, c in enumerate(sorted(lines[0]))}
    names_y = {c: f"y{i + 1}" for i, c in enumerate(sorted(lines[1]))}
    rule_cells: list[tuple[str, list[str]]] = []
    for ((x0, x1, y0, y1), geom), owner in zip(cells, owners, strict=True):
        if not owner:
            continue
        # should a clash remain, the region with most of the box's free area names it
        areas = {i: pieces[i].intersection(geom).area for i in owner}
        region = kinds[max(owner, key=lambda i: (areas[i], -i))]
        when = []
        if np.isfinite(x0):
            when.append(f"x > {names_x[x0]}")
        if np.isfinite(x1):
            when.append(f"x < {names_x[x1]}")
        if np.isfinite(y0):
            when.append(f"y > {names_y[y0]}")
        if np.isfinite(y1):
            when.append(f"y < {names_y[y1]}")
        rule_cells.append((region, when))
    kinds = [k for k in kinds if any(r == k for r, _ in rule_cells)]
    counts = {k: sum(1 for r, _ in rule_cells if r == k) for k in kinds}
    default = max(kinds, key=lambda k: (counts[k], -kinds.index(k)))
    rules = [{"region": r, "when": w} for r, w in rule_cells if r != default]
    rules.append({"region": default})
    return {
        "names": kinds,
        "lines": {
            **{n: {"x": c} for c, n in names_x.items()},
            **{n: {"y": c} for c, n in names_y.items()},
        },
        "rules": rules,
    }
