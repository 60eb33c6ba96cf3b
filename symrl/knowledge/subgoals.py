"""Symbolic sub-goals derived from a map's region lines (the options of the option learner).

The paper's region lines cut the world "at its joints"; where a line crosses free space between
two different regions it marks a passage (the door, here). A robot that aims the reflex's
goal-following input at a point of such a passage instead of at the goal itself no longer folds
into the concave corner, which is what the literal learner never un-learns
(``docs/ALGORITHM.md`` sections 5-6). This module finds the passages of any map automatically
and turns them into a small table of candidate sub-goals per region, so the learner only has to
*choose* among a handful of symbolic options per region. Nothing here is specific to the
``hailu2001`` map and nothing knows of TorchRL; the table is plain tensors.

Which passages a region gets comes from a graph of the map: its nodes are the connected pieces
of each region's free area (a thin wall may cut a region in two), its edges the passages (a
crossing blocked by a thin wall is none). A region's options are the passages that some route
from it to the goal crosses toward the goal, so a door into a dead end or back behind the robot
is never offered, whatever the goal's bearing.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import networkx as nx
import numpy as np
import shapely
import torch
from shapely.geometry import LineString, box
from shapely.ops import unary_union

from symrl.world.worldmap import WorldMap

__all__ = [
    "SubgoalConfig",
    "Passage",
    "SubgoalTable",
    "find_passages",
    "region_pieces",
    "routes",
    "build_subgoals",
    "passage_labels",
]


@dataclass(frozen=True)
class SubgoalConfig:
    """How sub-goals are derived from the region lines (metres)."""

    clearance: float = 0.26
    """Half the width the robot needs (its radius): a passage narrower than twice this is
    impassable and gives no sub-goal; points are kept this far from the passage's ends."""

    max_width: float = 2.0
    """Only passages at most this wide are bottlenecks worth aiming at; a wider crossing (the
    room/concave line, 5 m) is open floor and gives no sub-goal (it still links regions)."""

    along: tuple[float, ...] = (0.0, 0.8)
    """Positions along a passage: 0 is its centre, f shifts the point toward the goal's side by
    f times the usable half-width (the half-width minus ``clearance``)."""

    beyond: tuple[float, ...] = (0.0, 0.4)
    """Offsets across the line toward the goal's side: 0 is on the line, d is d metres past it."""

    past: bool = True
    """A region also gets the points past (``beyond`` > 0) a passage it is entered through on a
    route from the start to the goal: steering there first keeps the robot off the passage's far
    post when it turns to the goal."""

    min_clearance: float = 0.0
    """Candidates closer than this to any wall are dropped (metres from the point to the nearest
    wall; the robot's centre passes through the point). 0 keeps all."""

    merge: float = 0.15
    """Candidates closer than this to an earlier one (of the same region) are dropped."""

    visible: bool = True
    """Only points that some place of the region sees in a straight line (through free space,
    past no thin wall): the reflex steers straight at its sub-goal, and at a point behind walls
    (a door two offices away) it jams against the wall until the trial's budget runs out."""

    include_goal: bool = True
    """Option 0 of every region is the goal itself (the paper's reflex)."""

    resolution: float = 0.01
    """Sampling step along each region line."""

    def __post_init__(self) -> None:
        for name in ("clearance", "max_width", "merge", "resolution"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"SubgoalConfig.{name} must be a number >= 0, got {value!r}")
        if self.resolution <= 0:
            raise ValueError(f"SubgoalConfig.resolution must be > 0, got {self.resolution!r}")
        for name in ("along", "beyond"):
            value = getattr(self, name)
            if not isinstance(value, (tuple, list)) or not value:
                raise ValueError(f"SubgoalConfig.{name} must be a non-empty list, got {value!r}")


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

    def point(self, along: float, across: float) -> tuple[float, float]:
        """World point at ``along`` on the line (its own coordinate) and ``across`` past it."""
        c = self.intercept + self.normal * across
        return (c, along) if self.axis == 0 else (along, c)


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


def _clearance(world: WorldMap, xy: tuple[float, float]) -> float:
    """Distance from a point to the nearest wall segment."""
    seg = world.segments
    a, b = seg[:, :2], seg[:, 2:]
    d = b - a
    t = np.clip(((np.asarray(xy) - a) * d).sum(1) / (d * d).sum(1), 0.0, 1.0)
    return float(np.hypot(*(a + t[:, None] * d - np.asarray(xy)).T).min())


def _sights(pieces: list, region: str, step: float = 0.2) -> np.ndarray:
    """(n, 2) places of ``region`` to look from: a grid of ``step`` over its pieces, and one
    point inside each piece (a strip narrower than the grid still gets one)."""
    out = []
    for name, geom in pieces:
        if name != region:
            continue
        x0, y0, x1, y1 = geom.bounds
        grid = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
        xs, ys = grid[0].ravel(), grid[1].ravel()
        inside = shapely.contains_xy(geom, xs, ys)
        out.append(np.stack((xs[inside], ys[inside]), 1))
        rep = geom.representative_point()
        out.append(np.array([[rep.x, rep.y]]))
    return np.concatenate(out) if out else np.zeros((0, 2))


def _seen_from(free: shapely.Geometry, sights: np.ndarray, xy: tuple[float, float]) -> bool:
    """Whether a straight line from one of ``sights`` to ``xy`` stays in ``free``."""
    if not len(sights):
        return False
    ends = np.broadcast_to(np.asarray(xy, dtype=np.float64), sights.shape)
    lines = shapely.linestrings(np.stack((sights, ends), 1))
    return bool(shapely.covers(free, lines).any())


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


def find_passages(world: WorldMap, config: SubgoalConfig | None = None) -> list[Passage]:
    """Every crossing of a region line through free space between two different regions that no
    thin wall blocks, oriented toward the goal (``after`` is the side fewer passages from it)."""
    config = config or SubgoalConfig()
    eps = max(2 * config.resolution, 1e-3)
    pieces = region_pieces(world)
    raw = []
    for name, (axis_name, c) in world.regions.lines.items():
        axis = 0 if axis_name == "x" else 1
        for lo, hi, key in _free_runs(world, pieces, axis, c, eps, config.resolution):
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


def routes(world: WorldMap, passages: list[Passage]) -> tuple[dict[str, set[int]], set[int]]:
    """Which passages lead to the goal: per region, the indices of the passages some route from
    one of its pieces to the goal's piece crosses toward the goal (from ``before`` to ``after``);
    and the passages some route from the start crosses that way."""
    pieces = region_pieces(world)
    graph = nx.MultiGraph()
    graph.add_nodes_from(range(len(pieces)))
    for k, p in enumerate(passages):
        graph.add_edge(*p.pieces, key=k)
    goal = _goal_piece(world, pieces)

    def crossed_from(source: int) -> set[int]:
        used: set[int] = set()
        if source < 0 or source == goal:
            return used
        for path in nx.all_simple_edge_paths(graph, source, goal):
            here, keys = source, []
            for u, v, k in path:
                nxt = v if u == here else u
                if passages[k].pieces != (here, nxt):
                    break  # crosses this passage away from the goal: not a route toward it
                keys.append(k)
                here = nxt
            else:
                used.update(keys)
        return used

    ahead: dict[str, set[int]] = {name: set() for name in world.regions.names}
    for i, (name, _) in enumerate(pieces):
        ahead[name] |= crossed_from(i)
    return ahead, crossed_from(_nearest_piece(pieces, world.start.x, world.start.y))


@dataclass
class SubgoalTable:
    """Candidate sub-goals per region, padded to a rectangle.

    ``points`` (R, K, 2) float32 world points, ``valid`` (R, K) bool, ``labels[r][k]`` a name
    such as ``"goal"`` or ``"l2@+0.8/0.4"`` (line, along fraction, beyond offset). Option 0 is
    the goal when ``include_goal``. Region order follows the map's ``regions.names``.
    ``then`` (R, K, 2) float32: where the robot steers once it has reached an option's point,
    NaN for the goal (every option when ``then`` is None).
    """

    region_names: tuple[str, ...]
    points: torch.Tensor
    valid: torch.Tensor
    labels: list[list[str]]
    then: torch.Tensor | None = None

    @classmethod
    def of(
        cls, region_names: tuple[str, ...],
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


def passage_labels(passages: list[Passage]) -> list[str]:
    """The name of each passage in labels: its line, and ``#k`` (k-th along it) when the line
    crosses free space more than once, so that every label in a table is unique."""
    out = []
    for p in passages:
        along = sorted(q.lo for q in passages if q.line == p.line)
        out.append(p.line if len(along) == 1 else f"{p.line}#{along.index(p.lo) + 1}")
    return out


def build_subgoals(world: WorldMap, config: SubgoalConfig | None = None) -> SubgoalTable:
    """The sub-goal table of ``world``: per region, the goal plus points of the bottleneck
    passages that some route from the region to the goal crosses (and, with ``past``, points just
    past a passage the region is entered through on a route from the start)."""
    config = config or SubgoalConfig()
    passages = find_passages(world, config)
    ahead_of, from_start = routes(world, passages)
    names = passage_labels(passages)
    goal = (world.goal.x, world.goal.y)
    if config.visible:
        pieces = region_pieces(world)
        free = _cut_free_area(world)
        shapely.prepare(free)
    per_region: list[list[tuple[tuple[float, float], str]]] = []
    for region in world.regions.names:
        cands: list[tuple[tuple[float, float], str]] = []
        sights = _sights(pieces, region) if config.visible else None
        if config.include_goal:
            cands.append((goal, "goal"))
        for k, p in enumerate(passages):
            half = p.width / 2 - config.clearance
            ahead = k in ahead_of[region]
            just_crossed = config.past and p.after == region and k in from_start
            if p.width > config.max_width or half < 0 or not (ahead or just_crossed):
                continue
            centre = (p.lo + p.hi) / 2
            goal_along = goal[1] if p.axis == 0 else goal[0]
            sign = 1.0 if goal_along >= centre else -1.0
            for f in config.along:
                for d in config.beyond:
                    if not ahead and d <= 0:
                        continue  # behind the robot: only points past the line count
                    xy = p.point(centre + sign * f * half, d)
                    if not bool(world.in_free_area(*xy)):
                        continue
                    if _clearance(world, xy) < config.min_clearance:
                        continue
                    if any(math.dist(xy, q) < config.merge for q, _ in cands):
                        continue
                    if sights is not None and not _seen_from(free, sights, xy):
                        continue
                    cands.append((xy, f"{names[k]}@{f:+.1f}/{d:.1f}"))
        if not cands:
            raise ValueError(f"build_subgoals: region {region!r} has no candidate sub-goal")
        per_region.append(cands)
    return SubgoalTable.of(tuple(world.regions.names), per_region)
