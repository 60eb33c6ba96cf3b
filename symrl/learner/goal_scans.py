"""The goal re-found from the scans the robot read when it arrived there before.

Told only the region rules, the robot steers by its odometry, whose heading error (0.5 degrees
an action) integrates: after 60-100 actions the believed position is 0.5-1 m off. Where the goal
lies that far along a route, the robot drives onto its *believed* goal, misses the real disc
beside it, and circles the believed goal until the trial's actions run out, although the goal
is in plain sight of its sonar.

The robot has been at the goal before. At the end of each trial that reached it, the last scan
(the readings at arrival, when the robot's true centre was on the goal's disc) is kept with the
odometry pose it was read at, up to ``memory`` of them per robot, the newest replacing the
oldest. A robot that drives onto its believed goal's disc and out again without the trial
ending has shown its belief wrong there (with ``passing_by``, so has one that came within the
body and the reward's close distance of the disc and went farther off again: the reflex holds
a robot off a wall its belief does not see, and the belief then passes beside the goal); from
then on, for the rest of the trial, each step
matches the latest scan against each kept arrival scan and steers at the arrival point it
finds. The match is the map localiser's Gauss-Newton fit (``symrl.knowledge.localize``), run
on a "map" of the robot's own: the arrival scan's echoes, joined where neighbouring rays hit
near each other (the same wall), in the arrival pose's frame. A match counts when at least
``GOOD`` of the rays the remembered echoes explain fall within ``NEAR`` of them; the best
such arrival gives the aim. Until the belief passes through its goal nothing changes, so a
trial that arrives as it believes is untouched.

Nothing here reads the walls or the free space: only the robot's odometry, its sonar readings
and which trials reached the goal.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.knowledge.localize import MapLocalizer
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig

__all__ = ["GoalScans"]

GOOD = 0.7
"""Least share of the usable rays a match must explain to within :data:`NEAR`."""
NEAR = 0.05
"""A ray is explained when the remembered echoes predict it to within this (m; 5 sonar sigmas)."""
MIN_RAYS = 6
"""Fewest usable rays for a match (two walls' worth of a 24-sonar ring)."""


def echo_segments(robot: RobotConfig, sonar: np.ndarray) -> np.ndarray:
    """(k, 2, 2) segments through one scan's echoes (``sonar`` (n,) over the range) in the
    frame of the pose it was read at: two neighbouring rays' echoes are joined when they lie
    nearer each other than half their mean distance from the robot (or 0.5 m), i.e. when they
    are likely the same wall."""
    n = robot.n_sensors
    angles = np.arange(n) * (2.0 * math.pi / n)
    reading = np.asarray(sonar, dtype=np.float64) * robot.sonar_range
    echo = reading < robot.sonar_range * 0.999
    reach = reading + robot.radius
    points = np.stack((reach * np.cos(angles), reach * np.sin(angles)), axis=1)
    nxt = np.roll(np.arange(n), -1)
    gap = np.hypot(*(points - points[nxt]).T)
    joined = echo & echo[nxt] & (gap < np.maximum(0.5, 0.25 * (reach + reach[nxt])))
    return np.stack((points[joined], points[nxt[joined]]), axis=1)


def _relative(frame: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose`` (3,) in the frame of ``frame`` (3,)."""
    dx, dy = pose[0] - frame[0], pose[1] - frame[1]
    c, s = math.cos(frame[2]), math.sin(frame[2])
    return np.array([c * dx + s * dy, -s * dx + c * dy, pose[2] - frame[2]])


def _origin_seen_from(pose: np.ndarray, estimate: np.ndarray) -> np.ndarray:
    """Where the arrival frame's origin lies, as a point of ``pose``'s frame (the robot's
    believed pose), given the robot's ``estimate`` (3,) in the arrival frame."""
    x, y, h = estimate
    c, s = math.cos(h), math.sin(h)
    local = np.array([-(c * x + s * y), s * x - c * y])  # the origin in the robot's frame
    cp, sp = math.cos(pose[2]), math.sin(pose[2])
    return np.array(
        [pose[0] + cp * local[0] - sp * local[1], pose[1] + sp * local[0] + cp * local[1]]
    )


class GoalScans(BufferViews):
    """B robots' arrival scans and, per trial, whether each has passed through its believed
    goal and where it found the goal since.

    Buffers (learned, saved): ``poses`` (B, M, 3) the odometry poses of the kept arrivals,
    ``scans`` (B, M, n) their readings over the range, ``count`` (B,) how many arrivals so far
    (the slot of the next is ``count % M``)."""

    poses: torch.Tensor
    scans: torch.Tensor
    count: torch.Tensor

    def __init__(
        self,
        batch: int,
        *,
        goal: tuple[float, float],
        goal_radius: float,
        robot: RobotConfig,
        memory: int = 5,
        passing_by: bool = False,
    ) -> None:
        super().__init__()
        if memory < 1:
            raise ValueError(f"GoalScans: memory must be >= 1, got {memory}")
        self.goal = np.array(goal, dtype=np.float64)
        self.goal_radius = float(goal_radius)
        self.robot = robot
        # the belief within this of the goal's disc and off again is a pass too (0: off)
        self.near_margin = robot.radius + robot.close_distance if passing_by else 0.0
        self.register_buffer("poses", torch.zeros(batch, memory, 3, dtype=torch.float64))
        self.register_buffer(
            "scans", torch.ones(batch, memory, robot.n_sensors, dtype=torch.float64)
        )
        self.register_buffer("count", torch.zeros(batch, dtype=torch.int64))
        # per trial (plain arrays: a checkpoint's working state): the belief has been on the
        # goal's disc (and near it), has left it again (the goal is elsewhere), the goal found
        self.inside = np.zeros(batch, dtype=bool)
        self.near = np.zeros(batch, dtype=bool)
        self.passed = np.zeros(batch, dtype=bool)
        self.found = np.full((batch, 2), np.nan)
        # per robot and slot: the matcher on that arrival's echoes (built when first needed)
        self._matchers: dict[tuple[int, int], MapLocalizer | None] = {}

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial: their belief is trusted again."""
        self.inside[rows] = False
        self.near[rows] = False
        self.passed[rows] = False
        self.found[rows] = np.nan

    def summary(self, row: int) -> dict[str, int]:
        """Robot ``row``'s trial so far, for its trial record: whether its belief passed through
        the goal without arriving (``goal_passed``) and whether an arrival scan then gave the
        goal (``goal_refound``)."""
        return {
            "goal_passed": int(self.passed[row]),
            "goal_refound": int(not np.isnan(self.found[row, 0])),
        }

    # -- acting ---------------------------------------------------------------------------
    def aim(self, pose: np.ndarray, aim: np.ndarray, sonar: np.ndarray | None) -> np.ndarray:
        """The point each robot at odometry ``pose`` (B, 3) steers at (B, 2): ``aim``, the
        options' (and the remembered way's), until it has passed through its believed goal;
        from then on the goal as found from its arrival scans (``sonar`` (B, n) over the
        range), where a match was found. With ``passing_by``, a belief that leaves the disc
        widened by the body and the close distance, having been inside it, has passed too."""
        passed, found = self.passed, self.found
        distance = np.hypot(*(pose[:, :2] - self.goal).T)
        self._leave(self.inside, distance < self.goal_radius)
        if self.near_margin > 0:
            self._leave(self.near, distance < self.goal_radius + self.near_margin)
        if sonar is None or not passed.any():
            return aim
        out = aim.copy()
        for b in np.flatnonzero(passed).tolist():
            point = self._match(b, pose[b], sonar[b])
            if point is not None:
                found[b] = point
            if not np.isnan(found[b, 0]):
                out[b] = found[b]
        return out

    def _leave(self, was: np.ndarray, now: np.ndarray) -> None:
        """The beliefs that have been inside a disc (``was`` (B,)) and are not now (``now`` (B,):
        inside at this step) have passed, for a robot with an arrival scan to search by; ``was``
        then holds whether each has been in."""
        self.passed |= was & ~now & (self.arrays["count"] > 0)
        np.logical_or(was, now, out=was)

    def _match(self, b: int, pose: np.ndarray, sonar: np.ndarray) -> np.ndarray | None:
        """The arrival point that robot ``b``'s scan matches best, in its odometry frame
        (None: no arrival explains the scan)."""
        a = self.arrays
        reading = sonar * self.robot.sonar_range
        usable = reading < self.robot.sonar_range * 0.999
        best, best_share = None, GOOD
        for slot in range(min(int(a["count"][b]), a["poses"].shape[1])):
            matcher = self._matcher(b, slot)
            if matcher is None:
                continue
            start = _relative(a["poses"][b, slot], pose)[None]
            estimate = matcher(start, sonar[None])
            explained, predicted = matcher.predict(estimate)
            used = usable & explained[0]
            if used.sum() < MIN_RAYS:
                continue
            share = float(np.mean(np.abs(predicted[0][used] - reading[used]) < NEAR))
            if share >= best_share:
                best, best_share = _origin_seen_from(pose, estimate[0]), share
        return best

    def _matcher(self, b: int, slot: int) -> MapLocalizer | None:
        key = (b, slot)
        if key not in self._matchers:
            segments = echo_segments(self.robot, self.arrays["scans"][b, slot])
            self._matchers[key] = (
                MapLocalizer(
                    Walls(segments),
                    self.robot,
                    iterations=20,
                    prior_xy=1.0,
                    prior_heading=0.3,
                    max_move=0.2,
                    outlier=0.5,
                )
                if len(segments) >= 3
                else None
            )
        return self._matchers[key]

    # -- learning (the update calls this at a trial's end) --------------------------------
    def learn(self, row: int, pose: np.ndarray, sonar: np.ndarray) -> None:
        """Robot ``row`` reached the goal at odometry ``pose`` (3,) reading ``sonar`` (n,)."""
        a = self.arrays
        slot = int(a["count"][row]) % a["poses"].shape[1]
        a["poses"][row, slot] = pose
        a["scans"][row, slot] = sonar
        a["count"][row] += 1
        self._matchers.pop((row, slot), None)

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        self._matchers.clear()  # the arrivals are replaced: matchers built again
        super()._load_from_state_dict(*args, **kwargs)
