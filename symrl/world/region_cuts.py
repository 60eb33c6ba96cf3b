"""The cuts that split a map's free area into regions (``regions: auto``): door-like narrowings
and chords at concave corners.

Steps 1 and 2 of :mod:`symrl.world.autoregions` (its docstring says what counts as a narrowing
and which corners are cut, and how): :func:`narrowings` and :func:`corner_cuts` return the cuts
as ``(axis, c, a, b)``, the stretch ``a..b`` of the line ``axis = c`` (x = c when axis is 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.ops import unary_union

__all__ = ["AutoRegionConfig", "corner_cuts", "free_area", "narrowings", "wall_segments"]


@dataclass(frozen=True)
class AutoRegionConfig:
    """What counts as a door-like narrowing (metres)."""

    max_door: float = 1.5
    """Widest free stretch that can be a door."""
    min_door: float = 0.52
    """Narrowest: the robot's width (twice the B21's radius); anything narrower is no way."""
    probe: float = 0.3
    """How far to each side of a line the free stretch is measured again."""
    widen: float = 1.5
    """A stretch is a narrowing if the one beside it is at least this many times wider."""
    door_area: float = 1.0
    """Pieces smaller than this (square metres) are doors, larger ones rooms."""
    max_cut: float = 2.0
    """Longest chord a shallow concave corner is cut along (the sub-goal builder's widest
    passage): one whose free side spans less than 270 degrees, a slight bend in a wall."""
    sharp_cut: float = 5.0
    """Longest chord a sharp concave corner is cut along: one whose free side spans 270 degrees
    or more (a wall's free end, the outer corner of a pocket, a U or a pillar, the inner corner
    of a square bend). The sonar's range (``RobotConfig.sonar_range``)."""
    tie: float = 0.01
    """Chords this much longer than the one that resolved a corner are taken too."""


def free_area(boundary: np.ndarray, obstacles: list[np.ndarray], segments: np.ndarray):
    """The free area with the thin walls cut out as hair-thin slits."""
    free = Polygon(boundary)
    solid = [Polygon(p) for p in obstacles]
    solid += [
        LineString([(a, b), (c, d)]).buffer(1e-6, cap_style="flat") for a, b, c, d in segments
    ]
    return free.difference(unary_union(solid)) if solid else free


def _stretches(free, axis: int, at: list[float], lo: float, hi: float) -> list[list[tuple]]:
    """Free intervals along each line ``axis = c`` for ``c`` in ``at`` (x = c when axis is 0),
    sorted; one vectorised shapely intersection for all lines."""
    ends = np.array([[c, lo, c, hi] if axis == 0 else [lo, c, hi, c] for c in at], np.float64)
    cuts = shapely.intersection(shapely.linestrings(ends.reshape(-1, 2, 2)), free)
    out = []
    for cut in cuts:
        intervals = []
        for g in getattr(cut, "geoms", [cut]):
            if g.is_empty or g.geom_type != "LineString":
                continue
            coords = np.asarray(g.coords)[:, 1 - axis]
            intervals.append((float(coords.min()), float(coords.max())))
        out.append(sorted(intervals))
    return out


def _width_at(stretches: list[tuple[float, float]], t: float) -> float:
    for a, b in stretches:
        if a <= t <= b:
            return b - a
    return 0.0


def narrowings(
    free, bounds, coords, config: AutoRegionConfig
) -> list[tuple[int, float, float, float]]:
    """``(axis, c, a, b)``: the free stretch ``a..b`` of line ``axis = c`` is a narrowing.

    Stretches are read on the line (a gap in a thin wall lying on it) and a millimetre to either
    side (the mouth of a door through a thick wall, whose face the line runs along); the stretch
    beside must be wider on both sides, so the mouth of a long narrow lane is no door."""
    xmin, ymin, xmax, ymax = bounds
    spans = ((ymin - 1, ymax + 1), (xmin - 1, xmax + 1))
    edges = _ring_edges(free)
    found = set()
    for axis in (0, 1):
        lo, hi = spans[axis]
        lines = [(c, at) for c in coords[axis] for at in (c, c - 1e-3, c + 1e-3)]
        at_all = np.array([at for _, at in lines], dtype=np.float64)
        maybe = _may_hold_a_door(edges, axis, at_all, (lo, hi), config)
        lines = [line for line, check in zip(lines, maybe, strict=True) if check]
        doors = [
            (c, at, a, b)
            for (c, at), stretches in zip(
                lines, _stretches(free, axis, [at for _, at in lines], lo, hi), strict=True
            )
            for a, b in stretches
            if config.min_door <= b - a <= config.max_door
        ]
        # the free stretches ``probe`` metres to either side, through each door's middle
        probes = [at + s for _, at, _, _ in doors for s in (-config.probe, config.probe)]
        beside = _stretches(free, axis, probes, lo, hi)
        for k, (c, _, a, b) in enumerate(doors):
            mid = 0.5 * (a + b)
            widths = [_width_at(beside[2 * k + j], mid) for j in (0, 1)]
            if min(widths) >= config.widen * (b - a):
                found.add((axis, c, round(a, 6), round(b, 6)))
    return sorted(found)


def _ring_edges(free) -> np.ndarray:
    """The free area's outline (the thin walls' slits included) as segments ``(x0, y0, x1, y1)``."""
    rings = shapely.get_rings(shapely.get_parts(free))
    xy, ring = shapely.get_coordinates(rings, return_index=True)
    same = ring[:-1] == ring[1:]
    return np.concatenate([xy[:-1][same], xy[1:][same]], axis=1)


def _may_hold_a_door(
    edges: np.ndarray,
    axis: int,
    at: np.ndarray,
    span: tuple[float, float],
    config: AutoRegionConfig,
) -> np.ndarray:
    """Which lines ``axis = at`` can have a free stretch of door width, found without shapely.

    A stretch begins and ends where its line meets the outline, so a line on which no two such
    points lie ``min_door..max_door`` apart (give or take a rounding margin) has none; the others
    get the exact shapely intersection. One vectorised pass over all lines and edges replaces
    a polygon intersection per line (the cost of a 3000-point boundary)."""
    across, along = edges[:, [axis, axis + 2]], edges[:, [1 - axis, 3 - axis]]
    # the edges whose extent across the line reaches it (a search tree of their boxes)
    lo, hi = span
    ends = np.stack([at, np.full_like(at, lo), at, np.full_like(at, hi)], axis=1)
    ends = ends if axis == 0 else ends[:, [1, 0, 3, 2]]
    lines = shapely.linestrings(ends.reshape(-1, 2, 2))
    line_of, edge = shapely.STRtree(shapely.linestrings(edges.reshape(-1, 2, 2))).query(lines)
    a0, a1 = across[edge, 0], across[edge, 1]
    v0, v1 = along[edge, 0], along[edge, 1]
    flat = a0 == a1  # an edge lying on the line: both its ends
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(flat, v0, v0 + (at[line_of] - a0) * (v1 - v0) / (a1 - a0))
    line_of = np.concatenate([line_of, line_of[flat]])
    v = np.concatenate([v, v1[flat]])
    margin = 1e-6 * max(1.0, hi - lo)
    # one sorted key for all lines, each line's points far from the next line's
    key = line_of * (2.0 * (hi - lo) + config.max_door + 1.0) + (v - lo)
    order = np.argsort(key)
    key, line_of = key[order], line_of[order]
    first = np.searchsorted(key, key + config.min_door - margin, side="left")
    last = np.searchsorted(key, key + config.max_door + margin, side="right")
    out = np.zeros(len(at), dtype=bool)
    out[line_of[last > first]] = True
    return out


def wall_segments(
    boundary: np.ndarray, obstacles: list[np.ndarray], segments: np.ndarray
) -> np.ndarray:
    """Every wall as a segment ``(x0, y0, x1, y1)``: polygon edges and thin walls."""
    rings = [boundary, *obstacles]
    edges = [np.concatenate([r, np.roll(r, -1, axis=0)], axis=1) for r in rings]
    return np.concatenate([*edges, segments.reshape(-1, 4)])


def _directions(walls: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Angles (radians, 0..2 pi) of the walls leaving point ``p``."""
    a, b = walls[:, :2], walls[:, 2:]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    t = ((p - a) * d).sum(1) / np.maximum(length**2, 1e-300)
    cross = d[:, 0] * (p[1] - a[:, 1]) - d[:, 1] * (p[0] - a[:, 0])
    off = np.abs(cross) / np.maximum(length, 1e-300)
    on = (off < 1e-6) & (t > -1e-6) & (t < 1 + 1e-6) & (length > 1e-12)
    out = []
    for (ax, ay), (bx, by), ti in zip(a[on], b[on], t[on], strict=True):
        if ti < 1 - 1e-6:  # the wall goes on toward b
            out.append(np.arctan2(by - p[1], bx - p[0]))
        if ti > 1e-6:  # ... and back toward a
            out.append(np.arctan2(ay - p[1], ax - p[0]))
    return np.unique(np.round(np.mod(out, 2 * np.pi), 12))


def _open_sectors(free, p: np.ndarray, walls: np.ndarray) -> list[tuple[float, float]]:
    """The free angular sectors ``(from, to)`` around ``p`` between consecutive walls."""
    angles = _directions(walls, p)
    if len(angles) == 0:
        return []
    out = []
    for lo, hi in zip(angles, np.append(angles[1:], angles[0] + 2 * np.pi), strict=True):
        mid = 0.5 * (lo + hi)
        q = p + 1e-4 * np.array([np.cos(mid), np.sin(mid)])
        if shapely.contains_xy(free, q[0], q[1]):
            out.append((float(lo), float(hi)))
    return out


def _chord(walls: np.ndarray, p: np.ndarray, angle: float) -> tuple[float, np.ndarray]:
    """The chord from ``p`` along ``angle`` to the first wall it meets: its length and far end."""
    d = np.array([np.cos(angle), np.sin(angle)])
    d[np.abs(d) < 1e-12] = 0.0
    a, e = walls[:, :2], walls[:, 2:] - walls[:, :2]
    det = d[0] * -e[:, 1] + d[1] * e[:, 0]  # solve p + t d = a + u e
    rel = a - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rel[:, 0] * -e[:, 1] + rel[:, 1] * e[:, 0]) / det
        u = (d[0] * rel[:, 1] - d[1] * rel[:, 0]) / det
    crossing = (np.abs(det) > 1e-12) & (u >= -1e-9) & (u <= 1 + 1e-9) & (t > 1e-7)
    hits = list(t[crossing])
    # a wall lying on the ray's line ahead of it stops the ray at its nearer end
    line = (np.abs(det) <= 1e-12) & (np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) < 1e-9)
    for a0, e0 in zip(a[line], e[line], strict=True):
        ends = np.array([(a0 - p) @ d, (a0 + e0 - p) @ d])
        ahead = ends[ends > 1e-7]
        if len(ahead):
            hits.append(float(ahead.min()))
    length = float(min(hits))
    return length, p + length * d


def corner_cuts(
    free, walls: np.ndarray, cuts: list[tuple[int, float, float, float]], config: AutoRegionConfig
) -> list[tuple[int, float, float, float]]:
    """Chords that cut every concave corner of the free area into sectors of at most 180 degrees
    (:mod:`symrl.world.autoregions`, step 2), as ``(axis, c, a, b)`` like the narrowings."""
    corners = np.unique(np.round(walls.reshape(-1, 2), 9), axis=0)
    corners = corners[np.lexsort((corners[:, 1], corners[:, 0]))]
    found: list[tuple[int, float, float, float]] = []
    # the walls near a corner or along a ray come from a search tree (a 3000-point boundary)
    tree = shapely.STRtree(shapely.linestrings(walls.reshape(-1, 2, 2)))
    xmin, ymin, xmax, ymax = free.bounds
    reach = 2.0 * float(np.hypot(xmax - xmin, ymax - ymin))

    def segment(axis: int, c: float, a: float, b: float) -> np.ndarray:
        lo, hi = min(a, b), max(a, b)
        return np.array([c, lo, c, hi] if axis == 0 else [lo, c, hi, c])

    def near(geometry) -> np.ndarray:
        """The walls and cuts so far whose boxes meet ``geometry``."""
        static = walls[tree.query(geometry, predicate="dwithin", distance=1e-6)]
        return np.concatenate([static, *[segment(*k)[None] for k in cuts + found]])

    widest = _concave(free, walls, tree, corners)
    keep = widest > np.pi + 1e-9
    concave, sharp = corners[keep], widest[keep] >= _SHARP
    # a corner whose axis chords all run past ``short`` between the walls, with no cut that
    # near, can only need a chord longer than its limit: it is left whole
    short = np.where(sharp, config.sharp_cut, config.max_cut) + config.tie + 0.01
    near_wall = np.zeros(len(concave), dtype=bool)
    for group in (sharp, ~sharp):
        near_wall[group] = _short_chord(
            walls, tree, concave[group], float(short[group].max(initial=0.0))
        )
    for p, close, reach_p in zip(concave, near_wall, short, strict=True):
        if not close and not _cut_within(p, cuts + found, float(reach_p)):
            continue
        for lo, hi in _open_sectors(free, p, near(shapely.Point(p))):
            if hi - lo <= np.pi + 1e-9:
                continue
            limit = config.sharp_cut if hi - lo >= _SHARP else config.max_cut
            # axis directions strictly inside the sector, with their chords
            options = []
            for k in range(int(np.floor(lo / (np.pi / 2))) + 1, int(np.ceil(hi / (np.pi / 2)))):
                angle = k * np.pi / 2
                if angle - lo < 1e-9 or hi - angle < 1e-9:
                    continue
                ray = LineString([p, p + reach * np.array([np.cos(angle), np.sin(angle)])])
                length, far = _chord(near(ray), p, angle)
                options.append((length, angle, far))
            options.sort(key=lambda o: (o[0], o[1]))
            taken: list[tuple[float, float, np.ndarray]] = []
            for option in options:
                done = taken and _resolved(lo, hi, [t[1] for t in taken])
                if done and option[0] > taken[-1][0] + config.tie:
                    break
                taken.append(option)
            if not taken or not _resolved(lo, hi, [t[1] for t in taken]):
                continue
            if taken[-1][0] > limit:
                continue
            for _, angle, far in taken:
                axis = 0 if abs(np.cos(angle)) < 0.5 else 1  # a vertical chord lies on x = c
                c = float(p[0] if axis == 0 else p[1])
                a, b = sorted((float(p[1 - axis]), float(far[1 - axis])))
                found.append((axis, c, round(a, 6), round(b, 6)))
    return found


_SHARP = 1.5 * np.pi - 1e-9
"""A free sector at least this wide (270 degrees) makes a corner sharp."""


def _concave(free, walls: np.ndarray, tree, corners: np.ndarray) -> np.ndarray:
    """Each corner's widest free sector (radians; 0 where no sector is free) between the walls
    alone: a corner is concave where it exceeds 180 degrees.

    ``_open_sectors`` for all corners at once, without the cuts: a cut through or to a corner
    only splits its free sectors, so a corner whose sectors are at most 180 degrees here needs no
    chord, and only the few others get the corner-by-corner search (a 3000-point boundary has a
    corner per point)."""
    corner, wall = tree.query(shapely.points(corners), predicate="dwithin", distance=1e-6)
    p, a, b = corners[corner], walls[wall, :2], walls[wall, 2:]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    t = ((p - a) * d).sum(1) / np.maximum(length**2, 1e-300)
    cross = d[:, 0] * (p[:, 1] - a[:, 1]) - d[:, 1] * (p[:, 0] - a[:, 0])
    off = np.abs(cross) / np.maximum(length, 1e-300)
    on = (off < 1e-6) & (t > -1e-6) & (t < 1 + 1e-6) & (length > 1e-12)
    toward_b, toward_a = on & (t < 1 - 1e-6), on & (t > 1e-6)
    at = np.concatenate([corner[toward_b], corner[toward_a]])
    ends = np.concatenate([b[toward_b], a[toward_a]]) - corners[at]
    angle = np.round(np.mod(np.arctan2(ends[:, 1], ends[:, 0]), 2 * np.pi), 12)
    order = np.lexsort((angle, at))
    at, angle = at[order], angle[order]
    keep = np.ones(len(at), dtype=bool)
    keep[1:] = (at[1:] != at[:-1]) | (angle[1:] != angle[:-1])
    at, angle = at[keep], angle[keep]
    # each angle to the next one round the same corner (the last to the first plus 2 pi)
    last = np.ones(len(at), dtype=bool)
    last[:-1] = at[1:] != at[:-1]
    first = np.flatnonzero(np.r_[True, at[1:] != at[:-1]])
    nxt = np.empty_like(angle)
    nxt[:-1] = angle[1:]
    nxt[last] = angle[first] + 2 * np.pi
    mid = 0.5 * (angle + nxt)
    q = corners[at] + 1e-4 * np.stack([np.cos(mid), np.sin(mid)], axis=1)
    span = np.where(shapely.contains_xy(free, q[:, 0], q[:, 1]), nxt - angle, 0.0)
    out = np.zeros(len(corners))
    np.maximum.at(out, at, span)
    return out


def _short_chord(walls: np.ndarray, tree, corners: np.ndarray, short: float) -> np.ndarray:
    """Whether any of a corner's four axis chords meets a wall within ``short`` (as ``_chord``
    computes it, for all corners and directions at once)."""
    if len(corners) == 0:
        return np.zeros(0, dtype=bool)
    steps = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    p = np.repeat(corners, 4, axis=0)
    d = np.tile(steps, (len(corners), 1))
    rays = shapely.linestrings(np.stack([p, p + short * d], axis=1))
    ray, wall = tree.query(rays, predicate="dwithin", distance=1e-6)
    p, d, a = p[ray], d[ray], walls[wall, :2]
    e = walls[wall, 2:] - a
    det = d[:, 0] * -e[:, 1] + d[:, 1] * e[:, 0]
    rel = a - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rel[:, 0] * -e[:, 1] + rel[:, 1] * e[:, 0]) / det
        u = (d[:, 0] * rel[:, 1] - d[:, 1] * rel[:, 0]) / det
    crossing = (np.abs(det) > 1e-12) & (u >= -1e-9) & (u <= 1 + 1e-9) & (t > 1e-7) & (t <= short)
    line = (np.abs(det) <= 1e-12) & (np.abs(rel[:, 0] * d[:, 1] - rel[:, 1] * d[:, 0]) < 1e-9)
    ends = np.stack([(rel * d).sum(1), ((rel + e) * d).sum(1)], axis=1)
    along = line & ((ends > 1e-7) & (ends <= short)).any(1)
    out = np.zeros(len(corners), dtype=bool)
    out[ray[crossing | along] // 4] = True
    return out


def _cut_within(p: np.ndarray, cuts: list[tuple[int, float, float, float]], reach: float) -> bool:
    """Whether a cut ``(axis, c, a, b)`` comes within ``reach`` of point ``p``."""
    for axis, c, a, b in cuts:
        across, along = (p[0], p[1]) if axis == 0 else (p[1], p[0])
        gap = max(a - along, 0.0, along - b)
        if np.hypot(across - c, gap) <= reach:
            return True
    return False


def _resolved(lo: float, hi: float, angles: list[float]) -> bool:
    """Whether chords at ``angles`` split the sector ``lo..hi`` into parts of at most 180 deg."""
    edges = np.sort(np.array([lo, *angles, hi]))
    return bool((np.diff(edges) <= np.pi + 1e-9).all())
