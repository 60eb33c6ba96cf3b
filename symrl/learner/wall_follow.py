"""Out of a trap by following its wall, as a bug algorithm does.

Told only the region rules, the robot aims at a point of a border (or at the goal) and the
reflex steers there while avoiding what the sonar sees. Where the straight way to the aim runs
into a pocket the rules draw no line around (a cup open away from the aim, a recess on the
goal's bearing), aiming and avoiding balance inside the pocket: the robot circles there, in one
region, so the per-region timeout gives up option after option while every option's aim lies
beyond the same walls.

A robot whose last :data:`WINDOW` believed positions all lie within :data:`RADIUS` of their
mean (or whose last two windows' lie within twice the radius: a larger pocket, circled along its
walls) is trapped. It then follows the nearest wall (the nearest echo of its last
:data:`ECHOES` scans, placed from the odometry), keeping it on the side that turns it least from
its aim and :data:`CLEARANCE` away, round inner and outer corners alike, until it is
:data:`RADIUS` away from the trap and the sonar sees the straight way to its aim clear (a
tangent bug's leaving rule; a region line crossed does not end it, as lines may cut the pocket
itself). Trapped again where it was trapped before in the trial, or following for twice the
window, it takes the other side. The best trial's way then remembers how the robot got out
(``symrl.learner.remembered_way``).

Nothing here reads the walls or the free space: only the robot's odometry and its sonar.
"""

from __future__ import annotations

import math

import numpy as np

from symrl.world.robot import RobotConfig

__all__ = ["WallFollow"]

WINDOW = 40
"""Actions over which a trapped robot stays within :data:`RADIUS` (on its way it drives 8 m)."""
RADIUS = 1.0
"""Most distance (m) of the last :data:`WINDOW` believed positions from their mean, trapped;
over twice the window, twice the radius (a larger pocket, circled along its walls)."""
SCALES = 2
"""Windows checked: :data:`WINDOW` x 1, ..., x SCALES, each with its radius scaled alike."""
CLEARANCE = 0.6
"""Distance (m) from the robot's centre to the wall it follows (the body's radius and 0.34 m)."""
LOOKAHEAD = 1.0
"""How far ahead along the wall (m) the reflex is given its aim."""
ECHOES = 10
"""Scans whose echoes (placed from the odometry) the follow keeps: a thin wall's end, seen
edge-on, falls between the 15-degree rays of the latest scan but not of all ten."""
GAIN = 1.0
"""Turn (rad) toward the wall per metre beyond :data:`CLEARANCE` (at most 60 degrees either way)."""


def _wrap(angle: np.ndarray | float) -> np.ndarray | float:
    return np.remainder(np.asarray(angle) + math.pi, 2 * math.pi) - math.pi


class WallFollow:
    """Per robot of a batch: the trail of the trial's believed positions, whether the robot
    follows a wall (``following`` (B,) bool), on which side (+1: the wall on its left), where
    it was last trapped, and how often per trial."""

    def __init__(self, batch: int, robot: RobotConfig) -> None:
        n = robot.n_sensors
        self._angles = np.arange(n) * (2.0 * math.pi / n)
        self._range = float(robot.sonar_range)
        self._radius = float(robot.radius)
        self._trail = np.zeros((batch, SCALES * WINDOW, 2))
        self._scans = np.ones((batch, ECHOES, n))  # no echo until read
        self._poses = np.zeros((batch, ECHOES, 3))
        self._count = np.zeros(batch, dtype=np.int64)
        self.following = np.zeros(batch, dtype=bool)
        self._side = np.ones(batch)
        self._trap = np.full((batch, 2), np.inf)
        self._steps = np.zeros(batch, dtype=np.int64)
        self._follows = np.zeros(batch, dtype=np.int64)
        self._wall = np.full((batch, 2), np.nan)  # the point of the wall followed (NaN: none)

    def begin_trial(self, rows: np.ndarray) -> None:
        """Forget the trail and the follow of robots ``rows`` (a new trial)."""
        self._count[rows] = 0
        self._scans[rows] = 1.0
        self.following[rows] = False
        self._steps[rows] = 0
        self._follows[rows] = 0
        self._trap[rows] = np.inf
        self._wall[rows] = np.nan

    def summary(self, row: int) -> dict[str, int]:
        """The trial's wall follows of robot ``row`` (a trial-table column)."""
        return {"wall_follows": int(self._follows[row])}

    def aim(self, pose: np.ndarray, aim: np.ndarray, scan: np.ndarray | None) -> np.ndarray:
        """The points (B, 2) the reflex should aim at: ``aim`` (B, 2), or a point along the
        wall for a robot following one; ``pose`` (B, 3) the odometry poses, ``scan`` (B, n)
        the sonar readings over their range."""
        if scan is None:
            return aim
        out = aim.copy()
        xy = pose[:, :2]
        rows = np.arange(len(xy))
        self._trail[rows, self._count % (SCALES * WINDOW)] = xy
        self._scans[rows, self._count % ECHOES] = scan
        self._poses[rows, self._count % ECHOES] = pose
        self._count += 1
        distance = np.hypot(*(aim - xy).T)
        centres = self._trapped()
        for b in np.flatnonzero(self.following | ~np.isnan(centres[:, 0])).tolist():
            reach = scan[b] * self._range + self._radius
            if self.following[b]:
                self._steps[b] += 1
                away = np.hypot(*(xy[b] - self._trap[b])) >= RADIUS
                if away and self._clear(pose[b], aim[b], distance[b], reach):
                    self.following[b] = False
                    self._count[b] = 0
                    continue
                if self._steps[b] > 2 * WINDOW:
                    self._side[b] = -self._side[b]
                    self._steps[b] = 0
            else:
                centre = centres[b]
                self.following[b] = True
                self._follows[b] += 1
                self._steps[b] = 0
                if np.hypot(*(centre - self._trap[b])) < RADIUS:  # the same trap again
                    self._side[b] = -self._side[b]
                else:
                    wall = pose[b, 2] + self._angles[int(np.argmin(reach))]
                    bearing = math.atan2(aim[b, 1] - xy[b, 1], aim[b, 0] - xy[b, 0])
                    left = abs(float(_wrap(wall - math.pi / 2 - bearing)))
                    right = abs(float(_wrap(wall + math.pi / 2 - bearing)))
                    self._side[b] = 1.0 if left <= right else -1.0
                self._trap[b] = centre
                self._wall[b] = np.nan
            travel = self._along(b, pose[b], float(self._side[b]), self._echoes(b))
            out[b] = xy[b] + LOOKAHEAD * np.array([math.cos(travel), math.sin(travel)])
        return out

    def _trapped(self) -> np.ndarray:
        """(B, 2) the centre of each robot's trap (NaN: none) for robots not following one:
        their last ``k`` windows' believed positions all within ``k`` radii of their mean, for
        the least ``k`` up to :data:`SCALES` (all robots at once: this runs at every step)."""
        centres = np.full((len(self._count), 2), np.nan)
        size = SCALES * WINDOW
        for k in range(SCALES, 0, -1):  # the least scale last: it wins
            n = k * WINDOW
            rows = np.flatnonzero(~self.following & (self._count >= n))
            if not len(rows):
                continue
            index = (self._count[rows, None] - n + np.arange(n)) % size
            trail = self._trail[rows[:, None], index]  # (k, n, 2)
            centre = trail.mean(axis=1)
            spread = np.hypot(*(trail - centre[:, None]).transpose(2, 0, 1)).max(axis=1)
            inside = spread < k * RADIUS
            centres[rows[inside]] = centre[inside]
        return centres

    def _echoes(self, b: int) -> np.ndarray:
        """(M, n, 2) the echoes of robot ``b``'s last :data:`ECHOES` scans, placed from the
        odometry poses they were read at (NaN: no echo), worked out only while it follows."""
        scans, poses = self._scans[b], self._poses[b]
        reach = scans * self._range + self._radius
        angle = poses[:, 2:3] + self._angles
        points = np.stack(
            (
                poses[:, 0:1] + reach * np.cos(angle),
                poses[:, 1:2] + reach * np.sin(angle),
            ),
            -1,
        )
        points[scans >= 0.999] = np.nan
        return points

    def _along(self, b: int, pose: np.ndarray, side: float, echoes: np.ndarray) -> float:
        """The heading along the wall robot ``b`` follows, with it on ``side``, turned toward it
        when farther than :data:`CLEARANCE` and away when nearer. The wall is the nearest of
        the kept echoes ``echoes`` (M, n, 2) that lies within the body's diameter of the point
        followed at the last step (a gap the body cannot pass is wall; one it can, a door, is
        not: the follow rounds the door's post into it instead of taking up the wall beyond);
        the nearest of all when none does."""
        points = echoes.reshape(-1, 2)
        d = points - pose[:2]
        distance = np.hypot(d[:, 0], d[:, 1])
        if np.isnan(distance).all():  # no echo: turn toward the side
            self._wall[b] = np.nan
            return float(pose[2] + side * math.pi / 4)
        last = self._wall[b]
        if not np.isnan(last[0]):
            reach = max(2 * self._radius, float(np.hypot(*(last - pose[:2]))))
            near = np.hypot(*(points - last).T) <= reach
            if near.any():
                distance = np.where(near, distance, np.nan)
        k = int(np.nanargmin(distance))
        self._wall[b] = points[k]
        wall = math.atan2(d[k, 1], d[k, 0])
        turn = float(np.clip(GAIN * (distance[k] - CLEARANCE), -math.pi / 3, math.pi / 3))
        return float(wall - side * math.pi / 2 + side * turn)

    def _clear(self, pose: np.ndarray, aim: np.ndarray, distance: float, reach: np.ndarray) -> bool:
        """No echo nearer than the aim (or the sonar's range) on the two rays either side of
        its bearing."""
        bearing = math.atan2(aim[1] - pose[1], aim[0] - pose[0]) - pose[2]
        n = len(self._angles)
        k = int(float(np.remainder(bearing, 2 * math.pi)) // (2 * math.pi / n)) % n
        near = reach[[k, (k + 1) % n]]
        return bool((near >= min(distance, self._range)).all())
