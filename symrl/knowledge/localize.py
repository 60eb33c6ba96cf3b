"""Map localisation: the robot corrects its drifting odometry pose from one sonar scan.

The robot steers by the pose it believes, and its odometry drifts: 0.5 degrees of rotation
noise per action add up to decimetres over a trial. On the paper's world that drift, not the
motion noise itself, is what separates ``paper`` from the noise-free learner: with the same
motion noise and the true pose as belief, the last-5 total goes from -7.11 to -6.83 (tuning
seeds 0-39, ``docs/journal/learning.md``). The map is knowledge the robot already has, and its 24
sonars see the walls to within a centimetre, so it can tell where it is.

Each step, for every robot at once, the believed pose is the pose that best explains the
sonar readings in the map, near a predicted pose (a maximum a posteriori estimate with the
prediction as the prior): a few Gauss-Newton steps on

    sum_k w_k (r_k(p) - m_k)^2 / s^2 + (p - p_pred)^T P^-1 (p - p_pred),

p_pred the prediction (:class:`PoseTracker`: the odometry pose at a trial's first
observation, then the last belief moved by the odometry's increment), r_k the sonar rim
distance the map predicts from pose p (the ray cast of the physics), m_k the
reading, s the reading's noise, P the prior's spread. Its derivative is exact: a ray from
(x, y) at angle phi hits a wall with direction d at distance t = (w x d) / (u x d), so
dt/dx = -d_y / (u x d), dt/dy = d_x / (u x d), dt/dphi = t (u . d) / (u x d). Readings at the
sonar's range, rays grazing a wall and readings far from the prediction (a corner the ray
clips, a wall the pose's error puts another in front of) get less weight (Huber), and with
``outlier`` none beyond it: in a corridor whose door gaps repeat, a ray the model sends through
a gap the scan saw as wall (or the reverse) is mispredicted by metres, and under Huber a few such
rays pull the belief along the corridor a trust region per step until it locks onto the next
gap, a room's pitch off (``docs/journal/buildings.md``). A step
moves the position by at most ``max_move`` (a trust region): where the walls pin the pose only
across a corridor (one at 45 degrees, a long one), one ray mispredicted near a wall's end would
otherwise throw the estimate metres along it.

:class:`MapLocalizer` is a function of one observation and its prediction: no state, and a
mirrored world gives the mirrored pose; :class:`PoseTracker` carries each robot's belief
along its trial. The reward is the env's and stays on the odometry (the paper's f2), so the
correction only changes what the robot does, not how it is scored.

Written by hand: one batched ray cast of the physics per Gauss-Newton step and (B, 3, 3)
solves; a scan matcher from a library (e.g. an ICP on point clouds) would need the map as
points and has no prior.
"""

from __future__ import annotations

import math

import numpy as np

from symrl.world.geometry import Walls
from symrl.world.physics import wrap_angle
from symrl.world.robot import RobotConfig
from symrl.world.wall_queries import ray_directions
from symrl.world.wall_sets import WallSets

__all__ = ["MapLocalizer", "PoseTracker"]


class MapLocalizer:
    """The believed poses of B robots from their odometry poses and sonar scans.

    ``iterations`` Gauss-Newton steps, each with a ray cast at the estimate; ``prior_xy`` (m) and
    ``prior_heading`` (rad) the spread of the odometry's error, ``huber`` (m) the residual
    beyond which a reading counts less, ``min_incidence`` the smallest |cos| between a ray
    and the wall's normal that is used, ``edge`` (m) how near a wall's end a ray may hit and
    still be used, ``max_move`` (m; None: no bound) the largest position change of one step
    (the step is scaled down to it, heading included). ``walls``: one map for every robot, or
    (:class:`~symrl.world.wall_sets.WallSets`) a map per robot, row b's poses matched in set b.
    """

    def __init__(
        self,
        walls: Walls | WallSets,
        robot: RobotConfig,
        iterations: int = 5,
        prior_xy: float = 0.5,
        prior_heading: float = 0.2,
        huber: float = 0.05,
        min_incidence: float = 0.2,
        edge: float = 0.05,
        max_move: float | None = 0.1,
        outlier: float | None = None,
    ) -> None:
        if iterations < 1:
            raise ValueError(f"MapLocalizer: iterations must be >= 1, got {iterations}")
        if not prior_xy > 0 or not prior_heading > 0 or not huber > 0:
            raise ValueError(
                "MapLocalizer: prior_xy, prior_heading and huber must be > 0, got "
                f"{prior_xy}, {prior_heading}, {huber}"
            )
        if max_move is not None and not max_move > 0:
            raise ValueError(f"MapLocalizer: max_move must be > 0 or None, got {max_move}")
        if not edge >= 0:
            raise ValueError(f"MapLocalizer: edge must be >= 0, got {edge}")
        if outlier is not None and not outlier > 0:
            raise ValueError(f"MapLocalizer: outlier must be > 0 or None, got {outlier}")
        self.walls = walls
        self.robot = robot
        self.iterations = int(iterations)
        self.huber = float(huber)
        self.min_incidence = float(min_incidence)
        self.edge = float(edge)
        self.max_move = None if max_move is None else float(max_move)
        self.outlier = None if outlier is None else float(outlier)
        n = robot.n_sensors
        axes = np.arange(n) * (2.0 * math.pi / n)
        # a beam cone's reading is its nearest sub-ray (as in the physics): the model casts
        # every sub-ray and differentiates the nearest one
        self.cone_rays = robot.sonar_cone_rays if robot.sonar_cone_deg > 0 else 1
        self.offsets: np.ndarray = axes
        if self.cone_rays > 1:
            half = 0.5 * math.radians(robot.sonar_cone_deg)
            sub = np.linspace(-half, half, self.cone_rays)
            self.offsets = (axes[:, None] + sub[None, :]).ravel()
        self.cast_range = robot.radius + robot.sonar_range
        noise = max(robot.sonar_noise_std, 0.005)
        self.reading_weight = 1.0 / noise**2
        self.prior = np.diag([prior_xy**-2, prior_xy**-2, prior_heading**-2])
        # wall starts and directions, for the derivative of a range and where a ray hits
        self.wall_dx, self.wall_dy = walls.dx, walls.dy
        self.wall_length = np.sqrt(1.0 / walls.inv_len2)
        # the same with one more entry, wall 0's, read by wall -1 (no hit): a ray's wall index
        # gathers from them directly (no clamp to 0 before each gather)
        self._per_wall = tuple(
            np.append(v, v[0])
            for v in (
                walls.dx,
                walls.dy,
                -walls.dy,
                self.wall_length,
                walls.ax,
                walls.ay,
                walls.inv_len2,
            )
        )
        # per odometry pose of a first step (the start poses): its _geometry's rows
        self._start_geometry: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def __call__(
        self,
        odometry: np.ndarray,
        sonar: np.ndarray,
        start: np.ndarray | None = None,
        iterations: int | None = None,
        prior: np.ndarray | None = None,
    ) -> np.ndarray:
        """``odometry`` (B, 3) poses and ``sonar`` (B, n) readings normalised by the sonar
        range, as the env gives them; returns the believed poses (B, 3) float64. ``start``:
        where the Gauss-Newton steps begin (default: the odometry pose); ``iterations``: how
        many (default: the localiser's); ``prior``: the prior's (3, 3) weights for this call, or
        (B, 3, 3) one per robot (default: the localiser's, from ``prior_xy`` and
        ``prior_heading``)."""
        prior_pose = np.asarray(odometry, dtype=np.float64)
        measured = np.asarray(sonar, dtype=np.float64) * self.robot.sonar_range
        # a reading at the range cap says only "nothing nearer": no information on the pose
        usable = measured < self.robot.sonar_range * 0.999
        geometry: tuple[np.ndarray, ...] | None = None
        if start is None:
            pose = prior_pose.copy()
            if isinstance(self.walls, Walls):  # per-robot maps: a pose alone is not the key
                geometry = self._geometry_at_odometry(pose)
        else:
            pose = np.array(start, dtype=np.float64)
        for _ in range(self.iterations if iterations is None else iterations):
            pose = self._step(pose, prior_pose, measured, usable, geometry, prior)
            geometry = None
        return pose

    def predict(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """At poses ``pose`` (B, 3): which readings the map explains (a wall hit inside its
        ends, not grazing) and the readings it predicts (m), each (B, n)."""
        geometry = self._geometry(np.asarray(pose, dtype=np.float64))
        return geometry[0], geometry[-1]

    def _geometry_at_odometry(self, pose: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`_geometry` at odometry poses ``(k, 3)``. A first step starts from the odometry
        pose, which at a trial's first observation is the start pose: each pose's rows are
        remembered (bounded: start poses, not random ones) and a trial's first step skips
        the ray cast, most of a step."""
        keys = [row.tobytes() for row in pose]
        rows = [self._start_geometry.get(key) for key in keys]
        if all(row is not None for row in rows):
            fixed = np.array([row[0] for row in rows])  # type: ignore[index]
            block = np.array([row[1] for row in rows])  # type: ignore[index]
            return (fixed, *block.transpose(1, 0, 2))
        geometry = self._geometry(pose)
        if len(self._start_geometry) < 1024:
            for i, key in enumerate(keys):
                self._start_geometry[key] = (geometry[0][i], np.stack([g[i] for g in geometry[1:]]))
        return geometry

    def _geometry(self, pose: np.ndarray) -> tuple[np.ndarray, ...]:
        """What a step needs of the map at ``pose`` (B, 3), each ``(B, n)``: which readings the
        map can explain (a wall hit inside its ends, not grazing), u x d, the numerators of the
        range's derivative (x, y, heading) and the predicted readings."""
        angles = pose[:, 2:3] + self.offsets
        u = ray_directions(angles)  # the rays' directions, for the cast and here
        ux, uy = u[0], u[1]
        t, wall = self.walls.cast_many_walls(pose[:, 0], pose[:, 1], angles, self.cast_range, u)
        if self.cone_rays > 1:  # per sensor, the nearest sub-ray
            b, m = len(pose), self.cone_rays
            nearest = np.argmin(t.reshape(b, -1, m), axis=2)[..., None]
            t, wall, ux, uy = (
                np.take_along_axis(v.reshape(b, -1, m), nearest, 2)[..., 0]
                for v in (t, wall, ux, uy)
            )
        dx, dy, neg_dy, length, ax, ay, inv_len2 = (v[wall] for v in self._per_wall)
        cross = ux * dy - uy * dx  # u x d
        incidence = np.abs(cross) / length  # |cos| between the ray and the wall's normal
        # where along its wall the ray hits: near an end (a corner, a door post) the range's
        # derivative jumps, and a step on it bounces back and forth across the corner
        along = ((pose[:, 0:1] + t * ux - ax) * dx + (pose[:, 1:2] + t * uy - ay) * dy) * inv_len2
        inside = np.minimum(along, 1.0 - along) * length >= self.edge
        fixed = (wall >= 0) & (incidence >= self.min_incidence) & inside
        predicted = np.minimum(t - self.robot.radius, self.robot.sonar_range)
        return fixed, cross, neg_dy, dx, t * (ux * dx + uy * dy), predicted

    def _step(
        self,
        pose: np.ndarray,
        prior_pose: np.ndarray,
        measured: np.ndarray,
        usable: np.ndarray,
        geometry: tuple[np.ndarray, ...] | None = None,
        prior: np.ndarray | None = None,
    ) -> np.ndarray:
        """One Gauss-Newton step of the estimate at ``pose`` (``geometry``: :meth:`_geometry`
        there, if known; ``prior``: the prior's weights, if not the localiser's)."""
        fixed, cross, neg_dy, dx, dt_dphi, predicted = (
            self._geometry(pose) if geometry is None else geometry
        )
        ok = usable & fixed
        safe = np.where(ok, cross, 1.0)
        # the three columns divided into place (np.stack of three quotients copies them again)
        jac = np.empty((*cross.shape, 3))
        np.divide(neg_dy, safe, out=jac[..., 0])
        np.divide(dx, safe, out=jac[..., 1])
        np.divide(dt_dphi, safe, out=jac[..., 2])
        residual = np.where(ok, predicted - measured, 0.0)
        # Huber: huber / |r| beyond huber, else 1 (the minimum is 1 exactly up to huber)
        weight = np.minimum(self.huber / np.maximum(np.abs(residual), 1e-12), 1.0)
        if self.outlier is not None:
            ok = ok & (np.abs(residual) <= self.outlier)
        weight = np.where(ok, weight * self.reading_weight, 0.0)
        jw_t = np.swapaxes(jac * weight[..., None], 1, 2)  # (B, 3, n)
        offset = pose - prior_pose
        offset[:, 2] = wrap_angle(offset[:, 2])
        weights = self.prior if prior is None else prior
        # per robot's weights: one (1, 3) @ (3, 3) product per row, a single one's numbers
        pulled = offset @ weights if weights.ndim == 2 else (offset[:, None] @ weights)[:, 0]
        gradient = (jw_t @ residual[..., None])[..., 0] + pulled
        move = np.linalg.solve(jw_t @ jac + weights, -gradient[..., None])[..., 0]
        if self.max_move is not None:  # a trust region: the whole step scaled down to it
            shift = np.hypot(move[:, 0], move[:, 1])
            if (shift > self.max_move).any():
                move *= np.minimum(1.0, self.max_move / np.maximum(shift, 1e-12))[:, None]
        out = pose + move
        out[:, 2] = wrap_angle(out[:, 2])
        return out


class PoseTracker:
    """:class:`MapLocalizer` along each robot's trial, as a tracker: a robot's first
    observation of a trial takes the localiser's Gauss-Newton steps from the odometry pose,
    with the odometry as the prior (a reset puts it on the true pose); every later one takes a
    single step from its last belief moved by the odometry's increment (the odometry pose plus
    the last correction), and that prediction is also the prior's centre. The raw odometry's
    error grows without bound over a long trial (metres after a few hundred actions on a
    building floor), while one action's adds millimetres: a prior held on the raw odometry
    pulls the belief toward wherever it has drifted, and along a corridor, whose door gaps
    repeat, the scans then lock onto the wrong gap (a 30 m x 50 m floor: 5 of 30 trials lost
    with the belief a room's pitch off; 0 of 30 tracking the belief;
    ``docs/journal/buildings.md``). On the paper's world and the ``check`` suite the two are
    the same to within 0.001 of the optimum. An observation seen before returns its
    estimate again (the policy and the update ask for the same observations in turn). Per
    robot, so a robot's beliefs are the same alone or in a batch. :meth:`begin_trial` forgets
    the corrections of robots that start a new trial."""

    def __init__(self, localizer: MapLocalizer, batch: int) -> None:
        self.localizer = localizer
        width = 3 + localizer.robot.n_sensors
        # the last two observations (odometry, sonar) of each robot and their estimates, the
        # last first; NaN: none yet this trial (one array each: one comparison tests both)
        self._seen = np.full((2, batch, width), np.nan, dtype=np.float32)
        self._estimate = np.zeros((2, batch, 3))

    @property
    def correction(self) -> np.ndarray:
        """(B, 3): each robot's last estimate minus its odometry pose (0 before its first)."""
        out, last = self._offset()
        return np.where(np.isnan(last), 0.0, out)

    def _offset(self) -> tuple[np.ndarray, np.ndarray]:
        """Each robot's last estimate minus its odometry pose (NaN before its first) and that
        odometry pose."""
        last = self._seen[0, :, :3].astype(np.float64)
        out = self._estimate[0] - last
        out[:, 2] = wrap_angle(out[:, 2])
        return out, last

    def begin_trial(self, rows: np.ndarray) -> None:
        self._seen[:, rows] = np.nan

    def __call__(self, odometry: np.ndarray, sonar: np.ndarray) -> np.ndarray:
        """``odometry`` (B, 3) and ``sonar`` (B, n) as the env gives them: believed poses (B, 3)."""
        obs = np.concatenate((odometry, sonar), axis=1, dtype=np.float32)
        match = np.all(obs == self._seen, axis=2)  # (2, B): the last, the one before
        warm = ~np.isnan(self._seen[0, :, 0])  # the trial has had an observation
        if not match.any() and warm.all():  # the common step: every robot moved on
            pose = odometry.astype(np.float64)
            # every robot warm: the correction is the offset, no NaN to mask
            predicted = pose + self._offset()[0]
            estimate = self.localizer(predicted, sonar, predicted, 1)
            self._remember(slice(None), obs, estimate)
            return estimate
        last = match[0]
        known = last | match[1]
        out = np.where(last[:, None], self._estimate[0], self._estimate[1])
        new = np.flatnonzero(~known)
        if len(new):
            pose = odometry[new].astype(np.float64)
            scan = sonar[new]
            cold = ~warm[new]
            # a warm robot takes one step from its last correction, a cold one the localiser's
            # steps from its odometry pose (each row is computed on its own)
            estimate = np.empty((len(new), 3))
            if not cold.all():
                w = ~cold
                predicted = self.correction[new[w]] + pose[w]
                estimate[w] = self.localizer(predicted, scan[w], predicted, 1)
            if cold.any():
                estimate[cold] = self.localizer(pose[cold], scan[cold])
            self._remember(new, obs[new], estimate)
            out[new] = estimate
        return out

    def _remember(self, rows: slice | np.ndarray, obs: np.ndarray, estimate: np.ndarray) -> None:
        """Robots ``rows`` took ``estimate`` for the observation ``obs``."""
        self._seen[1, rows], self._estimate[1, rows] = self._seen[0, rows], self._estimate[0, rows]
        self._seen[0, rows], self._estimate[0, rows] = obs, estimate
