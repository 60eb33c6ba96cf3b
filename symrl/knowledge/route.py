"""The route of the ``map`` rung: a point ahead on the shortest path, re-planned from where the
robot believes it is.

A robot told the map's full geometry can plan (``symrl.knowledge.planner``), so one option of
every region is to follow the planner: each robot keeps the shortest path from where it stood
when it last planned, and aims at the point ``ahead`` metres along it from the path's point
nearest to it. When no point of the path between that nearest point and the aim lies within
``reach`` of the robot (the reflex's obstacle avoidance or a wrong turn has taken it off the
path), the path is planned again from where the robot believes it is (its pose from map
localisation). The same planner gives the studies their yardstick, from the world; here it
only ever sees the robot's ``Knowledge``. The route is the first option of every region of the
``map`` option source (``symrl.knowledge.option_tables``, labelled :data:`ROUTE`); the option
tables of every source are made through ``symrl.knowledge.option_sources`` (its
:func:`option_table` is importable from here too).
"""

from __future__ import annotations

import math

import numpy as np

from symrl.knowledge.option_sources import option_table
from symrl.knowledge.option_tables import ROUTE
from symrl.knowledge.planner import Plan, robot_clearances, shortest_path
from symrl.world.worldmap import WorldMap

__all__ = ["ROUTE", "Route", "option_table"]

_SPACING = 0.05
"""Metres between the points a path is resampled to (a quarter of an action)."""


class Route:
    """Per robot of a batch, its current path (None: not planned yet in this trial) and how far
    along it the robot has come."""

    def __init__(self, world: WorldMap, batch: int, ahead: float, reach: float) -> None:
        self.world = world
        self.ahead = max(1, round(ahead / _SPACING))  # the aim, in path points past the robot
        self.reach = reach
        self.paths: list[np.ndarray | None] = [None] * batch
        self.along = np.zeros(batch, dtype=np.int64)
        self.plans = 0
        """Paths planned so far (a cost measure for tests and benchmarks)."""

    def forget(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a new trial: their next aim plans afresh."""
        for b in np.atleast_1d(rows).tolist():
            self.paths[b] = None
        self.along[rows] = 0

    def aim(self, rows: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """The point each robot of ``rows`` (k,) at ``xy`` (k, 2) steers at: ``ahead`` metres
        along its path past the path's point nearest to it (the path's end if nearer)."""
        out = np.empty((len(rows), 2))
        for j, b in enumerate(rows.tolist()):
            here = xy[j]
            path = self.paths[b]
            i = None if path is None else self._nearest(path, int(self.along[b]), here)
            if i is None:  # not planned yet, or off the path: plan from here
                planned = self._replan(here)
                if planned is not None:
                    path, i = planned, 0
                elif path is not None:  # no way from here: the old path's nearest point
                    i = int(np.argmin(np.hypot(*(path - here).T)))
                else:  # no way from here, and none before: the goal
                    out[j] = (self.world.goal.x, self.world.goal.y)
                    continue
            self.paths[b], self.along[b] = path, i
            out[j] = path[min(i + self.ahead, len(path) - 1)]
        return out

    def _nearest(self, path: np.ndarray, start: int, here: np.ndarray) -> int | None:
        """The index of the point of ``path`` nearest ``here`` from ``start`` up to the current
        aim, if it lies within ``reach``."""
        window = path[start : start + self.ahead + 1]
        d = np.hypot(*(window - here).T)
        i = int(np.argmin(d))
        return start + i if d[i] <= self.reach else None

    def plan_from(self, here: np.ndarray) -> float | None:
        """The length (m) of the shortest way from ``here`` to the goal disc, as the route
        would plan it (None where there is none)."""
        plan = self._plan(here)
        return None if plan is None else plan.length

    def _replan(self, here: np.ndarray) -> np.ndarray | None:
        """The path from ``here`` (its first point), resampled every 5 cm; None where there
        is no way."""
        plan = self._plan(here)
        if plan is None:
            return None
        self.plans += 1
        return _resampled(np.asarray(plan.points, dtype=np.float64))

    def _plan(self, here: np.ndarray) -> Plan | None:
        """The shortest path from ``here``; nearer a wall than the planner's clearance, planned
        keeping the body radius only; None where there is no way even so."""
        start = (float(here[0]), float(here[1]))
        for clearance in (None, robot_clearances()[0]):
            try:
                return shortest_path(self.world, start=start, clearance=clearance)
            except ValueError:
                continue
        return None


def _resampled(points: np.ndarray) -> np.ndarray:
    """The polyline ``points`` as points every ``_SPACING`` metres of its length (its ends
    kept)."""
    if len(points) < 2:
        return points.reshape(-1, 2)
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
    n = max(1, math.ceil(float(s[-1]) / _SPACING))
    t = np.linspace(0.0, float(s[-1]), n + 1)
    return np.stack((np.interp(t, s, points[:, 0]), np.interp(t, s, points[:, 1])), axis=1)
