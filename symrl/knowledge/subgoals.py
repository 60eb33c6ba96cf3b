"""Symbolic sub-goals derived from a map's region lines (the options of the option learner).

The paper's region lines cut the world "at its joints"; where a line crosses free space between
two different regions it marks a passage (the door, here). A robot that aims the reflex's
goal-following input at a point of such a passage instead of at the goal itself no longer folds
into the concave corner, which is what the literal learner never un-learns
(``research/ALGORITHM.md`` section 5). This module finds the passages of any map automatically
and turns them into a small table of candidate sub-goals per region, so the learner only has to
*choose* among a handful of symbolic options per region. Nothing here is specific to the
``hailu2001`` map and nothing knows of TorchRL; the table is plain tensors.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import torch

from symrl.world.worldmap import WorldMap

__all__ = ["SubgoalConfig", "Passage", "SubgoalTable", "find_passages", "build_subgoals"]


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
    """A region also gets the points past (``beyond`` > 0) the passage it is entered through:
    steering there first keeps the robot off the passage's far post when it turns to the goal."""

    through: float = 0.0
    """A point short of this distance past its line gets a follow-up point this far past the line
    (same position along it): once the robot reaches the first, it steers through the passage
    instead of turning at once to the goal and into the post. 0: the follow-up is the goal."""

    min_clearance: float = 0.0
    """Candidates closer than this to any wall are dropped (metres from the point to the nearest
    wall; the robot's centre passes through the point). 0 keeps all."""

    merge: float = 0.15
    """Candidates closer than this to an earlier one (of the same region) are dropped."""

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

    @property
    def width(self) -> float:
        return self.hi - self.lo

    def point(self, along: float, across: float) -> tuple[float, float]:
        """World point at ``along`` on the line (its own coordinate) and ``across`` past it."""
        c = self.intercept + self.normal * across
        return (c, along) if self.axis == 0 else (along, c)


def _free_runs(world: WorldMap, axis: int, c: float, eps: float, res: float) -> list[tuple]:
    """Runs along line ``axis = c`` where both sides are free, with the region on each side."""
    xmin, xmax, ymin, ymax = world.bounds
    lo, hi = (ymin, ymax) if axis == 0 else (xmin, xmax)
    t = np.arange(lo + res / 2, hi, res)
    sides = []
    for s in (-eps, eps):
        pts = (np.full_like(t, c + s), t) if axis == 0 else (t, np.full_like(t, c + s))
        free = world.in_free_area(*pts)
        names = [world.regions.region_of(float(px), float(py)) for px, py in zip(*pts, strict=True)]
        sides.append((free, names))
    runs: list[tuple] = []
    start = None
    for i in range(len(t) + 1):
        key = None
        if i < len(t) and sides[0][0][i] and sides[1][0][i]:
            key = (sides[0][1][i], sides[1][1][i])
            if key[0] == key[1]:
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


def _goal_distances(world: WorldMap, links: list[tuple[str, str]]) -> dict[str, float]:
    """Passages between each region and the goal's region (breadth-first over the links)."""
    names = world.regions.names
    goal_region = world.regions.region_of(world.goal.x, world.goal.y)
    dist = {n: math.inf for n in names}
    dist[goal_region] = 0
    queue = deque([goal_region])
    while queue:
        here = queue.popleft()
        for a, b in links:
            for u, v in ((a, b), (b, a)):
                if u == here and dist[v] == math.inf:
                    dist[v] = dist[here] + 1
                    queue.append(v)
    return dist


def find_passages(world: WorldMap, config: SubgoalConfig | None = None) -> list[Passage]:
    """Every crossing of a region line through free space between two different regions."""
    config = config or SubgoalConfig()
    eps = max(2 * config.resolution, 1e-3)
    raw = []
    for name, (axis_name, c) in world.regions.lines.items():
        axis = 0 if axis_name == "x" else 1
        for lo, hi, (neg, pos) in _free_runs(world, axis, c, eps, config.resolution):
            raw.append((name, axis, c, lo, hi, neg, pos))
    dist = _goal_distances(world, [(r[5], r[6]) for r in raw])
    out = []
    for name, axis, c, lo, hi, neg, pos in raw:
        toward_pos = dist[pos] <= dist[neg]
        before, after = (neg, pos) if toward_pos else (pos, neg)
        out.append(Passage(name, axis, c, lo, hi, before, after, 1.0 if toward_pos else -1.0))
    return out


@dataclass
class SubgoalTable:
    """Candidate sub-goals per region, padded to a rectangle.

    ``points`` (R, K, 2) float32 world points, ``valid`` (R, K) bool, ``labels[r][k]`` a name
    such as ``"goal"`` or ``"l2@+0.8/0.4"`` (line, along fraction, beyond offset). Option 0 is
    the goal when ``include_goal``. Region order follows the map's ``regions.names``.
    """

    region_names: tuple[str, ...]
    points: torch.Tensor
    valid: torch.Tensor
    labels: list[list[str]]
    then: torch.Tensor | None = None
    """(R, K, 2) where to steer once ``points`` is reached (the goal when None or equal)."""

    @property
    def counts(self) -> torch.Tensor:
        """Options per region ``(R,)``."""
        return self.valid.sum(dim=1)

    def point(self, region: int, option: int) -> tuple[float, float]:
        if not bool(self.valid[region, option]):
            raise IndexError(f"SubgoalTable: region {region} has no option {option}")
        x, y = self.points[region, option].tolist()
        return float(x), float(y)

    def then_point(self, region: int, option: int) -> tuple[float, float] | None:
        """The follow-up point of an option, or None if it is the goal."""
        if self.then is None or not bool(self.valid[region, option]):
            return None
        x, y = self.then[region, option].tolist()
        return None if bool(torch.isnan(self.then[region, option]).any()) else (x, y)


def build_subgoals(world: WorldMap, config: SubgoalConfig | None = None) -> SubgoalTable:
    """The sub-goal table of ``world``: per region, the goal plus points of the bottleneck
    passages still ahead of it on a route to the goal (a passage is ahead when its ``before``
    region is no farther from the goal than the region itself)."""
    config = config or SubgoalConfig()
    passages = find_passages(world, config)
    dist = _goal_distances(world, [(p.before, p.after) for p in passages])
    goal = (world.goal.x, world.goal.y)
    per_region: list[list[tuple[tuple[float, float], str]]] = []
    follow: list[dict[int, tuple[float, float]]] = []
    for region in world.regions.names:
        cands: list[tuple[tuple[float, float], str]] = []
        nexts: dict[int, tuple[float, float]] = {}
        if config.include_goal:
            cands.append((goal, "goal"))
        for p in passages:
            half = p.width / 2 - config.clearance
            ahead = dist[p.before] <= dist[region]
            just_crossed = config.past and p.after == region
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
                    if config.through > d:
                        nexts[len(cands)] = p.point(centre + sign * f * half, config.through)
                    cands.append((xy, f"{p.line}@{f:+.1f}/{d:.1f}"))
        if not cands:
            raise ValueError(f"build_subgoals: region {region!r} has no candidate sub-goal")
        per_region.append(cands)
        follow.append(nexts)
    k = max(len(c) for c in per_region)
    points = torch.zeros(len(per_region), k, 2)
    valid = torch.zeros(len(per_region), k, dtype=torch.bool)
    then = torch.full((len(per_region), k, 2), float("nan"))
    for r, cands in enumerate(per_region):
        for j, (xy, _) in enumerate(cands):
            points[r, j] = torch.tensor(xy)
            valid[r, j] = True
            if j in follow[r]:
                then[r, j] = torch.tensor(follow[r][j])
    labels = [[name for _, name in cands] for cands in per_region]
    return SubgoalTable(tuple(world.regions.names), points, valid, labels, then)
