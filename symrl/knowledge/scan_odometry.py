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
from symrl.world.wall_sets import WallSets

__all__ = [
    "GOOD",
    "MIN_RAYS",
    "NEAR",
    "ScanOdometry",
    "echo_localizer",
    "echo_matcher",
    "echo_points",
    "echo_segments",
    "explained_share",
    "explained_shares",
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


def explained_shares(matcher: MapLocalizer, estimates: np.ndarray, sonar: np.ndarray) -> np.ndarray:
    """Per robot (k,), the share of its scan's usable rays (``sonar`` (k, n) over the range)
    that ``matcher``'s echoes predict to within :data:`NEAR` at ``estimates`` (k, 3); 0 with
    fewer than :data:`MIN_RAYS` rays to go by."""
    robot = matcher.robot
    reading = sonar * robot.sonar_range
    explained, predicted = matcher.predict(estimates)
    used = (reading < robot.sonar_range * 0.999) & explained
    count = used.sum(axis=1)
    near = (np.abs(predicted - reading) < NEAR) & used
    return np.where(count < MIN_RAYS, 0.0, near.sum(axis=1) / np.maximum(count, 1))


def explained_share(matcher: MapLocalizer, estimate: np.ndarray, sonar: np.ndarray) -> float:
    """:func:`explained_shares` of one scan (``sonar`` (n,)) at ``estimate`` (3,)."""
    return float(explained_shares(matcher, estimate[None], np.asarray(sonar)[None])[0])


def echo_localizer(
    walls: Walls | WallSets, robot: RobotConfig, iterations: int, outlier: float = 0.5
) -> MapLocalizer:
    """The Gauss-Newton matcher on echoes joined into ``walls`` (one scan's, or one per robot):
    a loose prior (the caller's per-call prior sets it), a 0.2 m trust region, and readings
    more than ``outlier`` (m) off left out (a wall one scan saw and the other did not)."""
    return MapLocalizer(
        walls,
        robot,
        iterations=iterations,
        prior_xy=1.0,
        prior_heading=0.3,
        max_move=0.2,
        outlier=outlier,
    )


def echo_matcher(robot: RobotConfig, sonar: np.ndarray, iterations: int) -> MapLocalizer | None:
    """The Gauss-Newton matcher on one scan's echoes (None: too few segments to match by)."""
    segments = echo_segments(robot, sonar)
    if len(segments) < 3:
        return None
    return echo_localizer(Walls(segments), robot, iterations)


class ScanOdometry:
    """B robots' beliefs from their odometry corrected by scan matching (see the module
    docstring). Called with each observation as :class:`~symrl.knowledge.localize.PoseTracker`
    is; an observation seen before returns its estimate again (the policy and the update ask
    for the same observations in turn). Per robot, so a robot's beliefs are the same alone or
    in a batch. :meth:`begin_trial` starts a robot's belief afresh on its odometry (a reset
    puts the odometry on the start pose). ``keyframe_actions``: actions between kept scans;
    ``iterations``: Gauss-Newton steps of a match; ``outlier`` (m): a reading the kept echoes
    predict farther off is left out of the match."""

    def __init__(
        self,
        robot: RobotConfig,
        batch: int,
        keyframe_actions: int = 5,
        iterations: int = 4,
        outlier: float = 0.5,
    ) -> None:
        if keyframe_actions < 1 or iterations < 1:
            raise ValueError(
                "ScanOdometry: keyframe_actions and iterations must be >= 1, got "
                f"{keyframe_actions} and {iterations}"
            )
        if not outlier > 0:
            raise ValueError(f"ScanOdometry: outlier must be > 0, got {outlier}")
        self.robot = robot
        self.keyframe_actions = int(keyframe_actions)
        self.iterations = int(iterations)
        self.outlier = float(outlier)
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
        # per robot, its keyframe's scan (as bytes), echo segments and their serial number;
        # the matcher on the last fit's segments, by their serial numbers (rebuilt when one
        # robot's keyframe changes)
        self._echoes: dict[int, tuple[bytes, np.ndarray | None, int]] = {}
        self._serial = 0
        self._matcher: tuple[tuple[int, ...], MapLocalizer] | None = None

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
        new = np.flatnonzero(~(match[0] | match[1]))
        if len(new):
            pose = np.asarray(odometry, dtype=np.float64)[new]
            out[new] = self._advance(new, pose, np.asarray(sonar, dtype=np.float64)[new])
            self.seen[1, new], self.estimate[1, new] = self.seen[0, new], self.estimate[0, new]
            self.seen[0, new], self.estimate[0, new] = obs[new], out[new]
        return out

    def _advance(self, rows: np.ndarray, odometry: np.ndarray, sonar: np.ndarray) -> np.ndarray:
        """Robots ``rows``' beliefs (k, 3) at new observations (``odometry`` (k, 3), ``sonar``
        (k, n)); each one's keyframe renewed when due. The matches are one batched fit, each
        robot's scan against its own keyframe's echoes (:class:`WallSets`): the numbers of one
        fit per robot, at a fraction of the numpy calls."""
        belief = odometry.copy()  # a trial's first observation: the odometry is the start pose
        good = np.zeros(len(rows), dtype=bool)
        later = np.flatnonzero(self.since[rows] >= 0)
        self.since[rows[later]] += 1
        steps = np.zeros((len(rows), 3))
        for i in later.tolist():
            steps[i] = relative_pose(self.key_odometry[rows[i]], odometry[i])
        echoes = {i: self._segments(int(rows[i])) for i in later.tolist()}
        fitted = np.array([i for i, e in echoes.items() if e[0] is not None], dtype=np.int64)
        if len(fitted):
            matcher = self._matcher_for([echoes[i] for i in fitted.tolist()])
            prior = np.stack([self._priors[int(self.since[rows[i]])] for i in fitted.tolist()])
            fit = matcher(steps[fitted], sonar[fitted], start=steps[fitted], prior=prior)
            good[fitted] = explained_shares(matcher, fit, sonar[fitted]) >= GOOD
            steps[fitted] = np.where(good[fitted][:, None], fit, steps[fitted])
        for i in later.tolist():
            belief[i] = _moved(self.key_belief[rows[i]], steps[i])
        renew = ~good | (self.since[rows] >= self.keyframe_actions)
        for i in np.flatnonzero(renew).tolist():
            b = int(rows[i])
            self.key_belief[b], self.key_odometry[b] = belief[i], odometry[i]
            self.key_scan[b], self.since[b] = sonar[i], 0
        return belief

    def _segments(self, b: int) -> tuple[np.ndarray | None, int]:
        """Robot ``b``'s keyframe's echo segments (None: too few to match by) and their serial
        number, kept until its keyframe changes."""
        key = self.key_scan[b].tobytes()
        kept = self._echoes.get(b)
        if kept is None or kept[0] != key:
            segments = echo_segments(self.robot, self.key_scan[b])
            usable = segments if len(segments) >= 3 else None
            self._serial += 1
            kept = self._echoes[b] = (key, usable, self._serial)
        return kept[1], kept[2]

    def _matcher_for(self, echoes: list[tuple[np.ndarray | None, int]]) -> MapLocalizer:
        """The matcher on these robots' keyframe echoes (segments and serial numbers), one row
        each: the last one again while no keyframe among them has changed (a few steps)."""
        serials = tuple(serial for _, serial in echoes)
        if self._matcher is None or self._matcher[0] != serials:
            walls = WallSets([segments for segments, _ in echoes if segments is not None])
            matcher = echo_localizer(walls, self.robot, self.iterations, self.outlier)
            self._matcher = (serials, matcher)
        return self._matcher[1]
