"""Where a map's region lines cross free space: the passages (the map tool of the ``passages``
rung), and the option table the options choose from.

The paper's region lines cut the world "at its joints"; where a line crosses free space between
two different regions it marks a passage (the door, here). :func:`find_passages` finds them on
any map, and orients each toward the goal over a graph of the map: its nodes are the connected
pieces of each region's free area (a thin wall may cut a region in two), its edges the passages
(a crossing blocked by a thin wall is none). The passages are handed to a robot as symbolic
segments of the region lines (``symrl.knowledge.borders.passages_of``); the sub-goal points are
made from them there. :class:`SubgoalTable` is the table of those points per region, plain
tensors (nothing here knows of TorchRL).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import shapely
import torch
from shapely.geometry import LineString, box
from shapely.ops import unary_union

from symrl.world.worldmap import WorldMap

__all__ = ["Passage", "SubgoalTable", "find_passages", "region_pieces"]


@dataclass(frozen=True)
class Passage:
    """Where region line ``line`` crosses free space between two different regions.

    ``axis`` 0 means the line is ``x = intercept`` (the passage runs along y); ``lo``/``hi`` bound
    the free crossing along the line; ``before``/``after`` are the regions on the side farther
    from / nearer to the goal's region (by the number of passages between them).
    """

    line: str
    axis: int
    intercept: float
    lo: float
    hi: float
    before: str
    after: str
    normal: float  # +1 if `after` lies on the side of increasing coordinate `axis`, else -1
    pieces: tuple[int, int] = (-1, -1)
    """Pieces (connected free areas of one region, see :func:`region_pieces`) on the ``before``
    and ``after`` sides."""

    @property
    def width(self) -> float:
        return self.hi - self.lo


def _cut_free_area(world: WorldMap) -> shapely.Geometry:
    """The free area with the thin walls cut out of it (a hair's width each)."""
    free = world.free_polygon
    cuts = [
        LineString([(a, b), (c, d)]).buffer(1e-6, cap_style="flat")
        for a, b, c, d in world.extra_segments
    ]
    return free.difference(unary_union(cuts)) if cuts else free


def region_pieces(world: WorldMap) -> list[tuple[str, shapely.Geometry]]:
    """The connected pieces of each region's free area, cut by the thin walls: ``(region,
    polygon)`` in the order of ``regions.names``, pieces of one region by their lowest point."""
    free = _cut_free_area(world)
    cells: dict[str, list] = {name: [] for name in world.regions.names}
    taken = None
    for rule in world.regions.rules:
        lo_hi = rule.bounds(world.bounds)
        if any(lo >= hi for lo, hi in lo_hi):
            continue
        cell = box(lo_hi[0][0], lo_hi[1][0], lo_hi[0][1], lo_hi[1][1])
        cells[rule.region].append(cell if taken is None else cell.difference(taken))
        taken = cell if taken is None else taken.union(cell)
    out: list[tuple[str, shapely.Geometry]] = []
    for name in world.regions.names:
        area = free.intersection(unary_union(cells[name]))
        parts = [g for g in getattr(area, "geoms", [area]) if g.area > 1e-9]
        parts.sort(key=lambda g: (g.bounds[1], g.bounds[0]))
        out.extend((name, g) for g in parts)
    return out


def _piece_of(pieces: list[tuple[str, shapely.Geometry]], x: np.ndarray, y: np.ndarray):
    """Index of the piece holding each point (-1 for none)."""
    out = np.full(np.shape(x), -1, dtype=np.int64)
    for i, (_, geom) in enumerate(pieces):
        out[shapely.intersects_xy(geom, x, y) & (out < 0)] = i
    return out


def _free_runs(
    world: WorldMap, pieces: list, axis: int, c: float, eps: float, res: float
) -> list[tuple]:
    """Runs along line ``axis = c`` where the short crossing of the line is free of walls, with
    the region and the piece on each side."""
    xmin, xmax, ymin, ymax = world.bounds
    lo, hi = (ymin, ymax) if axis == 0 else (xmin, xmax)
    t = np.arange(lo + res / 2, hi, res)
    sides = []
    for s in (-eps, eps):
        pts = (np.full_like(t, c + s), t) if axis == 0 else (t, np.full_like(t, c + s))
        free = world.in_free_area(*pts)
        names = world.regions.regions_of(*pts)
        sides.append((free, names, _piece_of(pieces, *pts)))
    if len(world.extra_segments):
        ends = []
        for s in (-eps, eps):
            across = np.full_like(t, c + s)
            ends.append(np.stack([across, t] if axis == 0 else [t, across], 1))
        crossings = shapely.linestrings(np.stack(ends, 1))
        walls = shapely.multilinestrings(world.extra_segments.reshape(-1, 2, 2))
        open_ = ~shapely.intersects(crossings, walls)
    else:
        open_ = np.ones_like(t, dtype=bool)
    runs: list[tuple] = []
    start = None
    for i in range(len(t) + 1):
        key = None
        if i < len(t) and sides[0][0][i] and sides[1][0][i] and open_[i]:
            key = (sides[0][1][i], sides[1][1][i], int(sides[0][2][i]), int(sides[1][2][i]))
            if key[0] == key[1] or min(key[2:]) < 0:
                key = None
        if start is not None and (key != start[1]):
            runs.append((float(t[start[0]] - res / 2), float(t[i - 1] + res / 2), start[1]))
            start = None
        if key is not None and start is None:
            start = (i, key)
    return runs


def _goal_distances(n: int, goal: int, links: list[tuple[int, int]]) -> list[float]:
    """Passages between each piece and the goal's piece (breadth-first over the links)."""
    dist = [math.inf] * n
    dist[goal] = 0
    queue = deque([goal])
    while queue:
        here = queue.popleft()
        for a, b in links:
            for u, v in ((a, b), (b, a)):
                if u == here and dist[v] == math.inf:
                    dist[v] = dist[here] + 1
                    queue.append(v)
    return dist


def _nearest_piece(pieces: list, x: float, y: float) -> int:
    """The piece holding the point, or the nearest one (a point on a thin wall is in none)."""
    here = shapely.Point(x, y)
    return min(range(len(pieces)), key=lambda i: (pieces[i][1].distance(here), i))


def _goal_piece(world: WorldMap, pieces: list) -> int:
    return _nearest_piece(pieces, world.goal.x, world.goal.y)


def find_passages(world: WorldMap, resolution: float = 0.01) -> list[Passage]:
    """Every crossing of a region line through free space between two different regions that no
    thin wall blocks, oriented toward the goal (``after`` is the side fewer passages from it);
    each line is sampled every ``resolution`` metres."""
    eps = max(2 * resolution, 1e-3)
    pieces = region_pieces(world)
    raw = []
    for name, (axis_name, c) in world.regions.lines.items():
        axis = 0 if axis_name == "x" else 1
        for lo, hi, key in _free_runs(world, pieces, axis, c, eps, resolution):
            raw.append((name, axis, c, lo, hi, *key))
    dist = _goal_distances(len(pieces), _goal_piece(world, pieces), [r[7:9] for r in raw])
    out = []
    for name, axis, c, lo, hi, neg, pos, pneg, ppos in raw:
        toward_pos = dist[ppos] <= dist[pneg]
        before, after = (neg, pos) if toward_pos else (pos, neg)
        sides = (pneg, ppos) if toward_pos else (ppos, pneg)
        normal = 1.0 if toward_pos else -1.0
        out.append(Passage(name, axis, c, lo, hi, before, after, normal, sides))
    return out


@dataclass
class SubgoalTable:
    """Candidate sub-goals per region, padded to a rectangle.

    ``points`` (R, K, 2) float32 world points, ``valid`` (R, K) bool, ``labels[r][k]`` a name
    such as ``"goal"``, ``"route"`` or ``"l2>door"`` (the border or passage on line ``l2``
    toward region ``door``). Region order follows the map's ``regions.names``.
    """

    region_names: tuple[str, ...]
    points: torch.Tensor
    valid: torch.Tensor
    labels: list[list[str]]

    @classmethod
    def of(
        cls,
        region_names: tuple[str, ...],
        per_region: list[list[tuple[tuple[float, float], str]]],
    ) -> SubgoalTable:
        """The table of ``per_region[r]``: region r's candidates ``(point, label)`` in order,
        padded to the longest row."""
        k = max(len(c) for c in per_region)
        points = torch.zeros(len(per_region), k, 2)
        valid = torch.zeros(len(per_region), k, dtype=torch.bool)
        for r, cands in enumerate(per_region):
            for j, (xy, _) in enumerate(cands):
                points[r, j] = torch.tensor(xy)
                valid[r, j] = True
        labels = [[name for _, name in cands] for cands in per_region]
        return cls(region_names, points, valid, labels)

    @property
    def counts(self) -> torch.Tensor:
        """Options per region ``(R,)``."""
        return self.valid.sum(dim=1)

    def point(self, region: int, option: int) -> tuple[float, float]:
        if not bool(self.valid[region, option]):
            raise IndexError(f"SubgoalTable: region {region} has no option {option}")
        x, y = self.points[region, option].tolist()
        return float(x), float(y)
