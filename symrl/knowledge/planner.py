"""The optimum a learner is held against: the shortest collision-free path to the goal disc.

Method: an exact **tangent visibility graph** for a disc robot among polygonal walls. Keeping a
clearance ``R`` (body radius + IR collision distance = 0.26 + 0.056 m by default) from every wall
is the same as moving a point among the walls grown by ``R``; every shortest path of that point is
made of straight segments tangent to circles of radius ``R`` around wall vertices and arcs of those
circles. The graph's nodes are the start, the tangent points (start-to-circle, circle-to-circle,
goal-to-circle) and the target points; every edge is checked against the walls, and Dijkstra
(networkx) picks the shortest. On maps of more than :data:`WHOLE_GRAPH_CORNERS` corners the same
graph is built only where an A* search reaches (:mod:`symrl.knowledge.lazy_search`), guided by a
lower bound of the way left that knows the walls (:mod:`symrl.knowledge.grid_bound`).

The target is the goal disc (the trial ends when the centre is within ``goal.radius``). A shortest
path first touches that disc either on an open arc of its rim, where its last leg points at the
goal centre (a tangent from the goal centre, cut at the rim), or at a rim point where the rim meets
the grown walls (found by bisection on the rim angle to ~1e-12 rad). Both are in the graph, so the
length is exact up to the arc sampling used only to *check* arcs against other walls (5 mm; an
arc that grazes another wall between samples by less than a few micrometres would be missed).

The planner is knowledge: an agent told the map's full geometry plans its sub-goals with it
(``learner/options.py``), and the studies divide every result by its length (``symrl plan``,
the "x optimum"), with the same code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from symrl.knowledge.grid_bound import grid_bound
from symrl.knowledge.lazy_search import LazySearch
from symrl.knowledge.path_checks import path_checker
from symrl.knowledge.tangent_graph import TangentGraph
from symrl.world import WorldMap

__all__ = ["Plan", "shortest_path", "robot_clearances", "WHOLE_GRAPH_CORNERS"]

WHOLE_GRAPH_CORNERS = 100
"""Up to this many wall corners the whole graph is built and searched (Dijkstra); above, the
lazy A* (:class:`~symrl.knowledge.lazy_search.LazySearch`), whose time grows with the part of
the map the search explores. Both give the same length (to 1e-15 relative on every shipped
world at three clearances and on the generated floors); among equal-length routes they may pick
different ones, so the shipped worlds (36 corners at most) keep the whole graph's routes. The
whole graph took 5.8 s on a 402-corner floor and 18 s on a 642-corner one, the lazy search
0.19 s and 0.31 s (CPU, shared machine)."""


@dataclass
class Plan:
    """A shortest path: its length, the actions it needs, and its geometry for plots."""

    length: float
    """Length of the path in metres (start centre to the first point inside the goal disc)."""
    actions: int
    """``ceil(length / step)``: fewest actions of ``step`` metres that can cover the path."""
    clearance: float
    """Distance kept from every wall (robot centre to wall), metres."""
    step: float
    points: np.ndarray
    """Dense polyline of the path (k, 2), points at most 5 mm apart along arcs."""
    waypoints: list[tuple[float, float]] = field(default_factory=list)
    """The graph nodes the path goes through (tangent points and the end point)."""
    method: str = "tangent visibility graph (exact segments and arcs) + Dijkstra"
    error_bound: float = 1e-6
    corners: tuple[int, ...] = ()
    """Indices (into the map's wall vertices) of the corners whose circles the path touches."""

    def to_dict(self) -> dict:
        """JSON-ready summary (no dense polyline)."""
        return {
            "length_m": self.length,
            "actions": self.actions,
            "clearance_m": self.clearance,
            "step_m": self.step,
            "waypoints": [list(map(float, w)) for w in self.waypoints],
            "method": self.method,
            "length_error_bound_m": self.error_bound,
        }


def robot_clearances() -> tuple[float, float, float]:
    """(body radius, IR collision distance, step) of the default robot, read from RobotConfig."""
    from symrl.world.robot import RobotConfig

    cfg = RobotConfig()
    return cfg.radius, cfg.ir_collision_distance, cfg.step


# --- the planner -------------------------------------------------------------------------------


def shortest_path(
    world: WorldMap,
    start: tuple[float, float] | tuple[float, float, float] | None = None,
    clearance: float | None = None,
    step: float | None = None,
    among: tuple[int, ...] | None = None,
) -> Plan:
    """Shortest path keeping ``clearance`` from every wall, from ``start`` to the goal disc.

    ``clearance`` defaults to body radius + IR collision distance of :class:`RobotConfig`;
    ``step`` to its translation per action. Raises ``ValueError`` if the start is too close to a
    wall or no path exists. ``among``: bend only round these corners (another plan's
    :attr:`Plan.corners`): a collision-free path in a few milliseconds, the shortest of those,
    not necessarily the shortest of all (``symrl plan``'s walk, 2 mm out of the optimum).
    """
    radius, ir_dist, default_step = robot_clearances()
    r = float(radius + ir_dist if clearance is None else clearance)
    step = float(default_step if step is None else step)
    if not (r > 0 and step > 0):
        raise ValueError(f"clearance and step must be positive, got {r} and {step}")
    s = np.array((world.start.x, world.start.y) if start is None else start[:2], dtype=float)
    g = np.array((world.goal.x, world.goal.y), dtype=float)
    rg = float(world.goal.radius)
    chk = path_checker(world, r)
    if not chk.point_ok(s):
        raise ValueError(
            f"start {tuple(map(float, s))} is closer than {r:.3f} m to a wall or outside the map"
        )
    if np.hypot(*(s - g)) <= rg:
        return Plan(0.0, 0, r, step, s[None, :], [tuple(s)])
    search: TangentGraph | LazySearch
    if among is not None:
        search = LazySearch(chk, s, g, rg, np.unique(np.asarray(among, dtype=np.intp)))
        length, route = search.run()
        method = "tangent visibility graph among the given corners (exact segments and arcs) + A*"
    elif len(chk.walls.vertices) > WHOLE_GRAPH_CORNERS:
        # the bound's grid at the body radius (or less) serves both plans of `symrl plan`
        search = LazySearch(chk, s, g, rg, bound=grid_bound(world, min(r, radius), g, rg))
        length, route = search.run()
        method = "tangent visibility graph built as searched (exact segments and arcs) + A*"
    else:
        search = TangentGraph(chk, s, g, rg)
        search.build()
        length, route = search.shortest_route()
        method = Plan.method
    return Plan(
        length=float(length),
        actions=int(math.ceil(float(length) / step - 1e-9)),
        clearance=r,
        step=step,
        points=search.polyline(route),
        waypoints=[(float(search.pos[k][0]), float(search.pos[k][1])) for k in route],
        method=method,
        corners=tuple(
            dict.fromkeys(int(k[1]) for k in route if isinstance(k, tuple) and k[0] == "C")
        ),
    )
