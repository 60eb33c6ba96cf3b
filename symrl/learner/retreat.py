"""Backing out of a trap by the way the robot came.

An option aimed past a wall the robot cannot see round (a pocket open toward it, a concave
corner, two regions whose options point at each other) holds the reflex where it is: the robot
circles or slides to and fro, and the options' timeout only fires once the region's actions run
out, which in a pocket cut by region lines they never do. The robot's own trail says it is
trapped: over the last ``window`` actions (the options' timeout) it got less than a tenth of the
way those actions could take it. It then steers back along its trail to where it was
``2 * window`` actions before (or the trial's start), and the options it had chosen in every
region it visited since are given up for the trial, so that the options choose anew there.

Nothing here reads the walls: only the odometry poses of the trial. ``tests/learner/
test_retreat.py`` checks the trap test and the way back.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["Retreat"]


class Retreat:
    """The trails and retreats of B robots in one trial each (nothing learned: reset with every
    trial, so not part of a saved state)."""

    def __init__(
        self,
        batch: int,
        max_actions: int,
        *,
        window: int,
        step: float,
        reach: float = 0.5,
        slack: float = 1.5,
    ) -> None:
        """``window``: the actions over which a robot that got less than a tenth of ``window``
        times its ``step`` length is trapped; a retreat's target nearer than ``reach`` is
        reached; one not reached within ``slack`` times the straight way's actions ends."""
        self.window = int(window)
        self.step = float(step)
        self.reach = float(reach)
        self.slack = float(slack)
        n = max_actions + 2
        self.trail = np.zeros((batch, n, 2))
        self.regions = np.full((batch, n), -1, dtype=np.int64)
        self.t = np.zeros(batch, dtype=np.int64)  # poses in the trail
        self.active = np.zeros(batch, dtype=bool)  # backing out at the last step
        self.target = np.zeros((batch, 2))
        self._left = np.zeros(batch)
        self._since = np.zeros(batch, dtype=np.int64)  # the trail's pose the retreat goes to
        self._quiet = np.zeros(batch, dtype=np.int64)  # no new retreat before this pose

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial: an empty trail."""
        self.t[rows] = 0
        self.active[rows] = False
        self._quiet[rows] = 0

    def observe(self, xy: np.ndarray, region: np.ndarray) -> list[tuple[int, set[int]]]:
        """Each robot's pose ``xy`` (B, 2) in ``region`` (B,) joins its trail; a trapped robot
        starts backing out. Returns the retreats that ended at this step, each (robot, the
        regions it visited since the pose it backed out to)."""
        rows = np.arange(len(xy))
        t = np.minimum(self.t, self.trail.shape[1] - 1)
        self.trail[rows, t] = xy
        self.regions[rows, t] = region
        self.t = t + 1
        ended: list[tuple[int, set[int]]] = []
        w = self.window
        for b in rows.tolist():
            now = int(t[b])
            if self.active[b]:
                self._left[b] -= 1.0
                if math.dist(xy[b], self.target[b]) < self.reach or self._left[b] < 0:
                    self.active[b] = False
                    self._quiet[b] = now + w
                    ended.append((b, set(self.regions[b, self._since[b] : now + 1].tolist())))
                continue
            if now < w or now < self._quiet[b]:
                continue
            if math.dist(self.trail[b, now], self.trail[b, now - w]) >= 0.1 * w * self.step:
                continue
            since = max(0, now - 2 * w)
            distance = math.dist(xy[b], self.trail[b, since])
            if distance < self.reach:  # trapped where it began: nothing to back out to
                self._quiet[b] = now + w
                continue
            self._since[b] = since
            self.target[b] = self.trail[b, since]
            self.active[b] = True
            self._left[b] = max(self.slack * distance / self.step, 5.0)
        return ended

    def aim(self, aim: np.ndarray) -> np.ndarray:
        """The points to steer at (B, 2): the retreat's target while backing out, else
        ``aim``."""
        return np.where(self.active[:, None], self.target, aim)
