"""Goal search: what the robot does when its odometry says it has arrived and the trial goes on.

The robot steers by odometry, and the trial ends when its *true* centre enters the goal disc.
On a long route the odometry drifts (0.5 degrees of rotation noise per action add up): after 70
actions in the ``office`` world the robot can stand on the goal by its odometry while the true
goal is half a metre away. The reflex then circles the point it believes is the goal until the
trial's budget runs out (with a perfect odometry the same learner fails 1 trial in 320 from
trial 5 on instead of 16: ``docs/LEARNING.md``).

The search is the knowledge a person would give the robot: once the odometry puts it well
inside the goal disc (within half its radius: nearer the rim a robot still on its way in
arrives a step later by itself, and searching there cost 0.22 a trial on the paper's world),
steer along an outward spiral around the goal, its turns ``spacing`` apart (at most
the disc's diameter, so the spiral passes over every point near the goal). The spiral turns the
way the robot is already turning about the goal, so a mirrored world gives the mirrored search.
Nothing here learns; per robot it keeps the spiral's radius and its sense of turning.
"""

from __future__ import annotations

import math

import numpy as np

from symrl.world.physics import wrap_angle

__all__ = ["GoalSearch"]


class GoalSearch:
    """The outward spiral of B robots around a goal (odometry coordinates, metres, radians).

    ``steer(pose, target, aim)`` returns the reflex's target angle and aim point, (B,) and
    (B, 2). They are unchanged for a robot that has not yet come within ``trigger`` times the
    goal radius (by its odometry) this trial. Otherwise they are the point ``lead`` radians
    ahead, about the goal, on the robot's spiral, which starts at ``start_fraction`` of the goal
    radius so that its first turn sweeps the disc around the odometry's goal.

    Tuned on the tuning seeds of ``office`` (0-39): a start at 0.5-0.75 of the radius and a lead
    of 1.0-1.3 rad left 3-4 failed trials in 640 from trial 5 on (41 without the search). With a
    lead of 0.7 rad, or a start on the rim, the robot's circle ran wider than the spiral and
    missed the disc (9-23 failed in 320). :meth:`begin_trial` ends the search of robots that
    start a new trial.
    """

    def __init__(
        self,
        goal: tuple[float, float],
        radius: float,
        batch: int,
        spacing: float = 0.5,
        step: float = 0.2,
        lead: float = 1.0,
        start_fraction: float = 0.75,
        trigger: float = 0.5,
    ) -> None:
        if not spacing > 0 or not radius > 0:
            raise ValueError(f"GoalSearch: spacing and radius must be > 0, got {spacing}, {radius}")
        self.goal = np.array(goal, dtype=np.float64)
        self.radius = float(radius)
        self.spacing = float(spacing)
        self.step = float(step)
        self.lead = float(lead)
        self.start_fraction = float(start_fraction)
        self.trigger = float(trigger)
        self.rho = np.full(batch, math.nan)  # the spiral's radius; NaN: not searching
        self.sense = np.ones(batch)  # +1 counter-clockwise about the goal, -1 clockwise

    @property
    def searching(self) -> np.ndarray:
        """(B,) bool: the robot has been deep inside the goal disc by its odometry this trial."""
        return ~np.isnan(self.rho)

    def begin_trial(self, rows: np.ndarray) -> None:
        self.rho[rows] = math.nan

    def steer(
        self, pose: np.ndarray, target: np.ndarray, aim: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``pose`` (B, 3) odometry; ``target`` (B,) the angle the reflex would steer at (left
        positive), ``aim`` (B, 2) its point. Searching robots get the spiral's instead."""
        dx, dy = pose[:, 0] - self.goal[0], pose[:, 1] - self.goal[1]
        r = np.hypot(dx, dy)
        searching = self.searching
        start = ~searching & (r < self.trigger * self.radius)
        if not (start.any() or searching.any()):
            return target, aim
        about = np.arctan2(dy, dx)  # the robot's angle about the goal
        if start.any():
            # the way the robot is turning about the goal: the sign of its heading's tangential
            # part (counter-clockwise when it is exactly radial)
            tangential = np.sin(pose[:, 2] - about)
            self.sense[start] = np.where(tangential < 0, -1.0, 1.0)[start]
            self.rho[start] = self.start_fraction * self.radius
        on = self.searching
        rho = self.rho
        # one step along the spiral widens it by spacing * step / (2 pi rho)
        rho[on] = rho[on] + self.spacing * self.step / (2 * math.pi * rho[on])
        ahead = about + self.sense * self.lead
        spiral = self.goal + np.stack((rho * np.cos(ahead), rho * np.sin(ahead)), axis=-1)
        new_aim = np.where(on[:, None], spiral, aim)
        d = new_aim - pose[:, :2]
        angle = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2])
        return np.where(on, angle, target), new_aim
