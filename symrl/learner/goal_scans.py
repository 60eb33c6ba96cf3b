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
ending has shown its belief wrong there; from then on, for the rest of the trial, each step
matches the latest scan against each kept arrival scan and steers at the arrival point it
finds. The match is the map localiser's Gauss-Newton fit (``symrl.knowledge.localize``), run
on a "map" of the robot's own: the arrival scan's echoes, joined where neighbouring rays hit
near each other (the same wall), in the arrival pose's frame. A match counts when at least
``GOOD`` of the rays the remembered echoes explain fall within ``NEAR`` of them; the best
such arrival gives the aim. Until the belief passes through its goal nothing changes, so a
trial that arrives as it believes is untouched.

With ``passing_by`` a belief that came within the body and the reward's close distance of the
disc and went farther off again searches too, for :data:`BESIDE_STEPS` actions after each such
pass: the reflex holds a robot off a wall its drifted belief does not see, and the belief then
runs beside its goal. Such a belief may also be
right (the goal behind a wall the robot goes round), and from the far side of a wall the
arrival's walls match as a mirror image; so a goal found this way is steered at only if it
lies off the believed goal's disc, no farther off than the odometry can have drifted in the
trial's actions (two standard deviations of the robot's own motion model), and in plain sight
of the latest scan.

With ``within_drift`` a belief also searches at every step it is within that drift of the
goal's disc, once the drift exceeds the disc's radius (before that the real goal is on the
believed disc): on a long route the goal can be in sight before the belief reaches it, and a
goal found then (held to the same checks) spares the drive onto the drifted belief and the
search after it.

Nothing here reads the walls or the free space: only the robot's odometry, its sonar readings
and which trials reached the goal.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.knowledge.scan_odometry import (
    GOOD,
    echo_localizer,
    echo_points,
    echo_segments,
    explained_shares,
    relative_pose,
)
from symrl.world.robot import RobotConfig, odometry_drift
from symrl.world.wall_sets import WallSets

__all__ = ["GoalScans"]

MATCH_ITERATIONS = 20
"""Gauss-Newton steps of a match: the arrival may lie a metre or more off, not the few
centimetres of the scan odometry's keyframe."""

BESIDE_STEPS = 10
"""Actions (2 m) a belief that passed beside its goal searches for it after each pass (the
goal, where it can be, is in sight then; a search every step for the rest of the trial costs
a scan match per step of every long exploring trial that brushed past the goal)."""


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
        within_drift: bool = False,
    ) -> None:
        super().__init__()
        if memory < 1:
            raise ValueError(f"GoalScans: memory must be >= 1, got {memory}")
        self.goal = np.array(goal, dtype=np.float64)
        self.goal_radius = float(goal_radius)
        self.robot = robot
        # the belief within this of the goal's disc and off again is a pass too (0: off)
        self.near_margin = robot.radius + robot.close_distance if passing_by else 0.0
        self.within_drift = bool(within_drift)
        self.register_buffer("poses", torch.zeros(batch, memory, 3, dtype=torch.float64))
        self.register_buffer(
            "scans", torch.ones(batch, memory, robot.n_sensors, dtype=torch.float64)
        )
        self.register_buffer("count", torch.zeros(batch, dtype=torch.int64))
        # per trial (plain arrays: a checkpoint's working state): the belief has been on the
        # goal's disc (and near it), has left the disc again (through) or only the wider one
        # (beside), or come within the odometry's drift of the disc (approached); the goal
        # found since
        self.inside = np.zeros(batch, dtype=bool)
        self.approached = np.zeros(batch, dtype=bool)
        self.near = np.zeros(batch, dtype=bool)
        self.through = np.zeros(batch, dtype=bool)
        self.beside = np.zeros(batch, dtype=bool)
        self.beside_steps = np.zeros(batch, dtype=np.int64)  # search steps left from beside
        self.found = np.full((batch, 2), np.nan)
        self.steps = np.zeros(batch, dtype=np.int64)  # the trial's actions so far
        # per robot and slot: that arrival's echo segments (None: too few to match by; built
        # when first needed)
        self._echoes: dict[tuple[int, int], np.ndarray | None] = {}

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial: their belief is trusted again."""
        for flags in (self.inside, self.near, self.through, self.beside, self.approached):
            flags[rows] = False
        self.found[rows] = np.nan
        self.steps[rows] = 0
        self.beside_steps[rows] = 0

    @property
    def passed(self) -> np.ndarray:
        """(B,) bool: whether each robot's belief has shown itself wrong in this trial: it
        passed through its goal without arriving, or beside it and the goal was then found
        elsewhere (a belief passing beside its goal may be right: the goal behind a wall), or
        came within its drift of the goal and found it off the believed disc."""
        return self.through | ((self.beside | self.approached) & ~np.isnan(self.found[:, 0]))

    def summary(self, row: int) -> dict[str, int]:
        """Robot ``row``'s trial so far, for its trial record: whether its belief passed through
        the goal without arriving, or beside or within its drift of it with the goal then found
        elsewhere (``goal_passed``: :attr:`passed`), and whether an arrival scan then gave the
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
        widened by the body and the close distance, having been inside it, has passed too;
        but the belief may be right there (the goal behind a wall the robot goes round), so
        only a goal found off the believed goal's disc and within the drift the odometry can
        have gathered (:meth:`drift`) is steered at. With ``within_drift``, a belief within
        that drift of the disc searches at every step there, once the drift exceeds the disc's
        radius, held to the same checks."""
        self.steps += 1
        distance = np.hypot(*(pose[:, :2] - self.goal).T)
        arrived = self.arrays["count"] > 0  # an arrival scan to search by
        self.through |= self.inside & (distance >= self.goal_radius) & arrived
        self.inside |= distance < self.goal_radius
        if self.near_margin > 0:
            near = distance < self.goal_radius + self.near_margin
            left = self.near & ~near & arrived  # each time the belief leaves the wider disc
            self.beside |= left
            self.beside_steps[left] = BESIDE_STEPS
            self.beside_steps[~left] -= 1
            self.near[:] = near
        close = np.zeros_like(arrived)
        if self.within_drift:  # within the drift of the disc, once the drift exceeds it
            reach = self.drift(self.steps)
            close = arrived & (reach > self.goal_radius) & (distance < self.goal_radius + reach)
            self.approached |= close
        searching, found = self.through | self.beside | self.approached, self.found
        if sonar is None or not searching.any():
            return aim
        out = aim.copy()
        # from beside: just after passing; within the drift: while there
        matching = searching & (self.through | (self.beside_steps > 0) | close)
        points = self._match(np.flatnonzero(matching), pose, sonar)
        for b in np.flatnonzero(searching).tolist():
            point = points.get(b)
            if point is not None and (
                self.through[b] or self._plausible(b, pose[b], sonar[b], point)
            ):
                found[b] = point
            if not np.isnan(found[b, 0]):
                out[b] = found[b]
        return out

    def drift(self, n: np.ndarray | int) -> np.ndarray:
        """Two standard deviations (m) of the odometry's position error after ``n`` actions,
        from the robot's motion model: the translation noise and the heading's random walk
        integrated along the path (as the crossing map counts it)."""
        robot, n = self.robot, np.asarray(n, dtype=np.float64)
        turn = math.radians(robot.rotation_noise_deg)
        return 2.0 * odometry_drift(n, robot.step, robot.translation_noise, turn)

    def _plausible(self, b: int, pose: np.ndarray, sonar: np.ndarray, point: np.ndarray) -> bool:
        """Whether robot ``b``'s goal found at ``point`` (its odometry frame) from beside the
        believed goal, or within its drift, can be the goal: off the believed goal's disc (else
        the belief is right), no farther than the odometry can have drifted this trial, and in
        plain sight of the latest scan (a wall between says the scan matched the arrival's walls
        from their other side)."""
        off = math.dist(point, self.goal)
        if not self.goal_radius <= off <= self.goal_radius + float(self.drift(self.steps[b])):
            return False
        points, _, echo = echo_points(self.robot, sonar)
        target = relative_pose(pose, np.array([point[0], point[1], 0.0]))[:2]  # the robot's frame
        length = math.hypot(*target)
        if length < 1e-9:
            return True
        ex, ey = target / length
        rx, ry = points[echo].T
        along = rx * ex + ry * ey
        across = np.abs(rx * ey - ry * ex)
        return not bool(((along > 0) & (along < length) & (across < self.robot.radius)).any())

    def _match(
        self, rows: np.ndarray, pose: np.ndarray, sonar: np.ndarray
    ) -> dict[int, np.ndarray]:
        """Per robot of ``rows``, the arrival point its scan matches best, in its odometry
        frame (absent: no arrival explains the scan). Every robot's scan is matched against
        each of its kept arrivals' echoes in one batched fit, one row per pair (the arrivals'
        echoes a :class:`WallSets`): each row's numbers are those of that pair's match alone."""
        a = self.arrays
        pairs: list[tuple[int, int]] = []
        sets: list[np.ndarray] = []
        for b in rows.tolist():
            for slot in range(min(int(a["count"][b]), a["poses"].shape[1])):
                segments = self._segments(b, slot)
                if segments is not None:
                    pairs.append((b, slot))
                    sets.append(segments)
        if not pairs:
            return {}
        matcher = echo_localizer(WallSets(sets), self.robot, MATCH_ITERATIONS)
        robots = [b for b, _ in pairs]
        start = np.stack([relative_pose(a["poses"][b, slot], pose[b]) for b, slot in pairs])
        estimates = matcher(start, sonar[robots])
        shares = explained_shares(matcher, estimates, sonar[robots])
        best: dict[int, np.ndarray] = {}
        best_share: dict[int, float] = {}
        for i, b in enumerate(robots):  # slot order: the later of equal shares wins
            if shares[i] >= best_share.get(b, GOOD):
                best[b], best_share[b] = _origin_seen_from(pose[b], estimates[i]), shares[i]
        return best

    def _segments(self, b: int, slot: int) -> np.ndarray | None:
        """Robot ``b``'s arrival ``slot``'s echo segments (None: too few to match by)."""
        key = (b, slot)
        if key not in self._echoes:
            segments = echo_segments(self.robot, self.arrays["scans"][b, slot])
            self._echoes[key] = segments if len(segments) >= 3 else None
        return self._echoes[key]

    # -- learning (the update calls this at a trial's end) --------------------------------
    def learn(self, row: int, pose: np.ndarray, sonar: np.ndarray) -> None:
        """Robot ``row`` reached the goal at odometry ``pose`` (3,) reading ``sonar`` (n,)."""
        a = self.arrays
        slot = int(a["count"][row]) % a["poses"].shape[1]
        a["poses"][row, slot] = pose
        a["scans"][row, slot] = sonar
        a["count"][row] += 1
        self._echoes.pop((row, slot), None)

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        self._echoes.clear()  # the arrivals are replaced: their echoes found again
        super()._load_from_state_dict(*args, **kwargs)
