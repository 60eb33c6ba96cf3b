"""The odometry corrected by the robot's own scans: each scan matched against one read a few
actions before.

The odometry's heading takes a random error of about half a degree each action, and the error
integrates: along a 12 m route the believed position is half a metre to a metre off, enough to
miss a door or drive past the goal. The sonar ring sees the same walls from one action to the
next, and a wall seen from two poses tells how the robot turned and moved between them more
exactly than the wheels do. So every ``keyframe_actions`` actions the robot keeps its scan
(a *keyframe*) with the pose it believed there; each later scan is matched against the
keyframe's echoes, joined where neighbouring rays hit near each other (the same wall), and the
match, with the odometry's increment since the keyframe as its prior, gives the robot's pose
relative to the keyframe. The belief is the keyframe's belief moved by that pose. A scan the
keyframe's echoes explain poorly (fewer than :data:`GOOD` of its rays within :data:`NEAR`, or
fewer than :data:`MIN_RAYS` rays to go by) keeps the odometry's increment and starts a new
keyframe.

The error still grows (each keyframe adds its match's error), but by less than the odometry's:
on three long tuning worlds the position error after 60 actions falls by about a third to a
half (``docs/journal/scan-odometry.md``). The fit is the map localiser's Gauss-Newton
(:class:`~symrl.knowledge.localize.MapLocalizer`) on a "map" of the robot's own echoes: it
reads the robot's sonar and odometry and nothing of the world's walls, so any rung may use it.
"""

from __future__ import annotations

import math

import numpy as np

from symrl.knowledge.localize import MapLocalizer
from symrl.world.geometry import Walls
from symrl.world.physics import wrap_angle
from symrl.world.robot import RobotConfig, odometry_drift

__all__ = [
    "GOOD",
    "MIN_RAYS",
    "NEAR",
    "ScanOdometry",
    "echo_matcher",
    "echo_points",
    "echo_segments",
    "explained_share",
    "relative_pose",
]

GOOD = 0.7
"""Least share of the usable rays a match must explain to within :data:`NEAR`."""
NEAR = 0.05
"""A ray is explained when the remembered echoes predict it to within this (m; 5 sonar sigmas)."""
MIN_RAYS = 6
"""Fewest usable rays for a match (two walls' worth of a 24-sonar ring)."""


def echo_points(robot: RobotConfig, sonar: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each ray of one scan (``sonar`` (n,) over the range) ends, (n, 2) in the frame of
    the pose it was read at, how far from the robot's centre (n,), and which rays echoed (n,)
    bool (else nothing within range)."""
    n = robot.n_sensors
    angles = np.arange(n) * (2.0 * math.pi / n)
    reading = np.asarray(sonar, dtype=np.float64) * robot.sonar_range
    reach = reading + robot.radius
    points = np.stack((reach * np.cos(angles), reach * np.sin(angles)), axis=1)
    return points, reach, reading < robot.sonar_range * 0.999


def echo_segments(robot: RobotConfig, sonar: np.ndarray) -> np.ndarray:
    """(k, 2, 2) segments through one scan's echoes (``sonar`` (n,) over the range) in the
    frame of the pose it was read at: two neighbouring rays' echoes are joined when they lie
    nearer each other than half their mean distance from the robot (or 0.5 m), i.e. when they
    are likely the same wall."""
    n = robot.n_sensors
    points, reach, echo = echo_points(robot, sonar)
    nxt = np.roll(np.arange(n), -1)
    gap = np.hypot(*(points - points[nxt]).T)
    joined = echo & echo[nxt] & (gap < np.maximum(0.5, 0.25 * (reach + reach[nxt])))
    return np.stack((points[joined], points[nxt[joined]]), axis=1)


def relative_pose(frame: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose`` (3,) in the frame of ``frame`` (3,)."""
    dx, dy = pose[0] - frame[0], pose[1] - frame[1]
    c, s = math.cos(frame[2]), math.sin(frame[2])
    return np.array([c * dx + s * dy, -s * dx + c * dy, pose[2] - frame[2]])


def _moved(frame: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The pose ``offset`` (3,) of ``frame``'s frame, in the frame ``frame`` (3,) is given in."""
    c, s = math.cos(frame[2]), math.sin(frame[2])
    return np.array(
        [
            frame[0] + c * offset[0] - s * offset[1],
            frame[1] + s * offset[0] + c * offset[1],
            float(wrap_angle(np.array(frame[2] + offset[2]))),
        ]
    )


def explained_share(matcher: MapLocalizer, estimate: np.ndarray, sonar: np.ndarray) -> float:
    """The share of one scan's usable rays (``sonar`` (n,) over the range) that ``matcher``'s
    echoes predict to within :data:`NEAR` at ``estimate`` (3,); 0 with fewer than
    :data:`MIN_RAYS` rays to go by."""
    robot = matcher.robot
    reading = sonar * robot.sonar_range
    explained, predicted = matcher.predict(estimate[None])
    used = (reading < robot.sonar_range * 0.999) & explained[0]
    if used.sum() < MIN_RAYS:
        return 0.0
    return float(np.mean(np.abs(predicted[0][used] - reading[used]) < NEAR))


def echo_matcher(robot: RobotConfig, sonar: np.ndarray, iterations: int) -> MapLocalizer | None:
    """The Gauss-Newton matcher on one scan's echoes (None: too few segments to match by)."""
    segments = echo_segments(robot, sonar)
    if len(segments) < 3:
        return None
    return MapLocalizer(
        Walls(segments),
        robot,
        iterations=iterations,
        prior_xy=1.0,
        prior_heading=0.3,
        max_move=0.2,
        outlier=0.5,
    )


class ScanOdometry:
    """B robots' beliefs from their odometry corrected by scan matching (see the module
    docstring). Called with each observation as :class:`~symrl.knowledge.localize.PoseTracker`
    is; an observation seen before returns its estimate again (the policy and the update ask
    for the same observations in turn). Per robot, so a robot's beliefs are the same alone or
    in a batch. :meth:`begin_trial` starts a robot's belief afresh on its odometry (a reset
    puts the odometry on the start pose)."""

    def __init__(
        self, robot: RobotConfig, batch: int, keyframe_actions: int = 5, iterations: int = 4
    ) -> None:
        if keyframe_actions < 1 or iterations < 1:
            raise ValueError(
                "ScanOdometry: keyframe_actions and iterations must be >= 1, got "
                f"{keyframe_actions} and {iterations}"
            )
        self.robot = robot
        self.keyframe_actions = int(keyframe_actions)
        self.iterations = int(iterations)
        n = robot.n_sensors
        # the prior's weights per action count since the keyframe: the odometry's own drift
        # over those actions (position and heading), floored at the sonar's resolution
        turn = math.radians(robot.rotation_noise_deg)
        counts = np.arange(self.keyframe_actions + 1, dtype=np.float64)
        xy = np.maximum(odometry_drift(counts, robot.step, robot.translation_noise, turn), 0.02)
        heading = np.maximum(turn * np.sqrt(counts), 0.005)
        self._priors = [np.diag([a**-2, a**-2, h**-2]) for a, h in zip(xy, heading, strict=True)]
        # per robot (plain arrays: a checkpoint's working state): the keyframe's belief,
        # odometry pose and scan, and the actions since it (-1: no keyframe yet this trial)
        self.key_belief = np.zeros((batch, 3))
        self.key_odometry = np.zeros((batch, 3))
        self.key_scan = np.ones((batch, n))
        self.since = np.full(batch, -1, dtype=np.int64)
        # the last two observations (odometry, sonar) of each robot and their estimates
        self.seen = np.full((2, batch, 3 + n), np.nan, dtype=np.float32)
        self.estimate = np.zeros((2, batch, 3))
        # how far (m) the belief lay from the odometry at the last observation of each robot's
        # last finished trial: what the scans corrected (its trial record)
        self.correction = np.zeros(batch)
        self._matchers: dict[int, tuple[bytes, MapLocalizer | None]] = {}

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial (the env's reset, after their last trial's final
        observation): the finished trial's correction is kept for its record."""
        off = np.hypot(*(self.estimate[0, rows, :2] - self.seen[0, rows, :2]).T)
        self.correction[rows] = np.nan_to_num(off)  # no observation yet: no correction
        self.since[rows] = -1
        self.seen[:, rows] = np.nan

    def summary(self, row: int) -> dict[str, float]:
        """Robot ``row``'s last finished trial, for its trial record: how far the scans had
        moved its belief from the odometry at the trial's last observation
        (``scan_correction_m``)."""
        return {"scan_correction_m": float(self.correction[row])}

    def __call__(self, odometry: np.ndarray, sonar: np.ndarray) -> np.ndarray:
        """``odometry`` (B, 3) and ``sonar`` (B, n) as the env gives them: believed poses (B, 3)."""
        obs = np.concatenate((odometry, sonar), axis=1, dtype=np.float32)
        match = np.all(obs == self.seen, axis=2)  # (2, B): the last, the one before
        out = np.where(match[0][:, None], self.estimate[0], self.estimate[1])
        pose = np.asarray(odometry, dtype=np.float64)
        scans = np.asarray(sonar, dtype=np.float64)
        for b in np.flatnonzero(~(match[0] | match[1])).tolist():
            out[b] = self._advance(b, pose[b], scans[b])
            self.seen[1, b], self.estimate[1, b] = self.seen[0, b], self.estimate[0, b]
            self.seen[0, b], self.estimate[0, b] = obs[b], out[b]
        return out

    def _advance(self, b: int, odometry: np.ndarray, sonar: np.ndarray) -> np.ndarray:
        """Robot ``b``'s belief at a new observation; its keyframe renewed when due."""
        if self.since[b] < 0:  # a trial's first observation: the odometry is the start pose
            self._keep(b, odometry, odometry, sonar)
            return odometry.copy()
        self.since[b] += 1
        step = relative_pose(self.key_odometry[b], odometry)
        good = False
        matcher = self._matcher(b)
        if matcher is not None:
            fit = matcher(step[None], sonar[None], prior=self._priors[int(self.since[b])])[0]
            good = explained_share(matcher, fit, sonar) >= GOOD
            if good:
                step = fit
        belief = _moved(self.key_belief[b], step)
        if not good or self.since[b] >= self.keyframe_actions:
            self._keep(b, belief, odometry, sonar)
        return belief

    def _keep(self, b: int, belief: np.ndarray, odometry: np.ndarray, sonar: np.ndarray) -> None:
        self.key_belief[b], self.key_odometry[b], self.key_scan[b] = belief, odometry, sonar
        self.since[b] = 0

    def _matcher(self, b: int) -> MapLocalizer | None:
        """Robot ``b``'s matcher on its keyframe's echoes (rebuilt when the keyframe changes)."""
        key = self.key_scan[b].tobytes()
        kept = self._matchers.get(b)
        if kept is None or kept[0] != key:
            kept = self._matchers[b] = (
                key,
                echo_matcher(self.robot, self.key_scan[b], self.iterations),
            )
        return kept[1]
