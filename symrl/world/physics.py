"""The B21's physics for B robots at once: the one model behind the Gymnasium and TorchRL envs.

:class:`RobotBatch` holds B robots in one :class:`~symrl.world.worldmap.WorldMap` and steps them
together, with no Python loop over robots on the geometric path (the ``Walls.*_many`` queries).
The model is the paper's (see :class:`symrl.world.env.Hailu2001Env` for the full description):
rotate (+ noise), translate 0.20 m (+ noise), a real collision when the swept disc touches a
wall, a virtual one when an IR reflectance after the move exceeds the threshold, the emergency
reversal to the pose before the translation, odometry, noisy and clipped sonar, r = f1 + f2, the
goal tested on the TRUE pose and truncation after ``max_actions`` actions.

Randomness: every robot has its own ``np.random.Generator``, held by the caller and passed to
:meth:`RobotBatch.reset` and :meth:`RobotBatch.step`. Per step robot b draws
``standard_normal(n + 2)`` from its generator (rotation, translation, the n sonars) when any noise
is on, and ``standard_normal(n)`` at its reset when the sonar noise is on.

Robot b's trajectory is bitwise the same whatever B is and wherever b sits in the batch: every
operation is element-wise or a per-row reduction (min/max, exact in any order), the ray cast's
matrix product is one BLAS call per row, and the few transcendental functions whose numpy SIMD
loops round differently from the C library (atan2, hypot, pow) go through ``math`` per element,
as the original scalar model did. A batch of one takes a float lane (:meth:`RobotBatch.step`
on Python floats and the scalar ``Walls`` methods, the same operations in the same order), since
numpy's per-call overhead dominates a single robot; the tests hold it bitwise equal to the array
lane (a robot alone against the same robot inside larger batches) and to the trajectories of the
scalar model the Gymnasium env had before, which it reproduces exactly.

The parts live by job: the sensing in :mod:`symrl.world.sensing`, the readings in
:mod:`symrl.world.readings`, the exact angle arithmetic in :mod:`symrl.world.exact_math`
(``Readings``, ``goal_reading`` and ``wrap_angle`` are importable from here too).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from symrl.world.exact_math import PI as _PI
from symrl.world.exact_math import TWO_PI as _TWO_PI
from symrl.world.exact_math import goal_direction, goal_reading, math_map, wrap_angle
from symrl.world.readings import (
    Readings,
    batch_readings,
    columns,
    observation_bounds,
    one_readings,
)
from symrl.world.robot import RobotConfig
from symrl.world.sensing import Sensors
from symrl.world.spatial import walls_for
from symrl.world.worldmap import WorldMap

__all__ = ["Readings", "RobotBatch", "goal_reading", "wrap_angle"]


class RobotBatch:
    """B robots in one world, reset and stepped together (numpy float64, no torch).

    State (replaced, never mutated in place, so arrays handed out earlier stay valid):
    ``true_pose`` and ``odometry_pose`` ``(B, 3)`` float64 (new arrays on every access),
    ``actions_taken`` ``(B,)`` int64 and ``sonar`` ``(B, n)`` float64, the last sonar reading in
    metres (for rendering). Before the first :meth:`reset` every robot sits at the map's start,
    unsensed.
    """

    def __init__(
        self,
        world: WorldMap,
        robot: RobotConfig,
        size: int,
        noise: bool = True,
        max_actions: int = 200,
    ) -> None:
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
            raise ValueError(f"RobotBatch: size must be a positive integer, got {size!r}")
        if isinstance(max_actions, bool) or not isinstance(max_actions, int) or max_actions < 1:
            raise ValueError(f"max_actions must be a positive integer, got {max_actions!r}")
        self.world = world
        self.robot = robot
        self.size = int(size)
        self.noise = bool(noise)
        self.max_actions = max_actions
        # many walls: queried through a spatial index (the sonar's reach; the disc's sweep)
        self.walls = walls_for(
            world, robot.radius + robot.sonar_range, robot.radius + 3.0 * robot.step + 0.1
        )
        self._valid_poses: set[bytes] = set()  # float64 (x, y, heading) rows that passed
        self.sensors = Sensors(self.walls, robot)
        n = robot.n_sensors
        self.n_sensors = n
        # clearance from which a virtual collision is impossible (reflectance well below the
        # threshold); the exact test runs only on robots closer than this
        self._virtual_reach = robot.radius + robot.ir_collision_distance + 1e-6
        self._sonar_std = robot.sonar_noise_std if self.noise else 0.0
        self._rot_std = math.radians(robot.rotation_noise_deg) if self.noise else 0.0
        self._trans_std = robot.translation_noise * robot.step if self.noise else 0.0
        self._noisy = self._sonar_std > 0 or self._rot_std > 0 or self._trans_std > 0
        self._goal = (world.goal.x, world.goal.y, world.goal.radius)

        # the state, one (B,) array per coordinate (columns are cheaper to update than (B, 3))
        ones = np.ones(self.size)
        self._x, self._y = world.start.x * ones, world.start.y * ones
        self._h = wrap_angle(world.start.heading * ones)
        self._xo, self._yo, self._ho = self._x.copy(), self._y.copy(), self._h.copy()
        self.actions_taken = np.zeros(self.size, dtype=np.int64)
        self.sonar = np.zeros((self.size, n))
        # closest wall points (relative) and clearance of each true pose: reused by the next step
        self._ex, self._ey, self._clear = self.walls.closest_many(self._x, self._y)

    _STATE = (
        "_x",
        "_y",
        "_h",
        "_xo",
        "_yo",
        "_ho",
        "actions_taken",
        "sonar",
        "_ex",
        "_ey",
        "_clear",
    )

    def state(self) -> dict[str, np.ndarray]:
        """Every robot's physics state between two steps (copies; a run snapshot)."""
        return {name: np.array(getattr(self, name)) for name in self._STATE}

    def load_state(self, state: dict[str, np.ndarray]) -> None:
        """Go on from :meth:`state` (same world, robots and size)."""
        for name in self._STATE:
            setattr(self, name, np.array(state[name]))

    @property
    def true_pose(self) -> np.ndarray:
        """(B, 3) float64: the true poses (x, y, heading), headings in [-pi, pi]."""
        return columns(self._x, self._y, self._h)

    def odometry_xy(self, b: int) -> tuple[float, float]:
        """Robot b's odometry position as floats (for the Gymnasium env's ``odometry_path``)."""
        return float(self._xo[b]), float(self._yo[b])

    @property
    def odometry_pose(self) -> np.ndarray:
        """(B, 3) float64: the poses the robots believe."""
        return columns(self._xo, self._yo, self._ho)

    # --- spaces --------------------------------------------------------------------------

    def observation_bounds(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """(low, high) float32 per observation key, one robot's shape (see
        :func:`symrl.world.readings.observation_bounds`)."""
        return observation_bounds(self.world.bounds, self.robot, self.max_actions)

    # --- queries ---------------------------------------------------------------------------

    def sense(
        self, x: np.ndarray, y: np.ndarray, heading: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances (metres) and IR reflectances ``(k, n)`` at k poses (no
        state change): for planners, figures and benchmarks."""
        x, y, h = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (x, y, heading))
        rim, refl, _ = self.sensors.sense(x, y, h, None)
        return rim, refl

    def check_poses(self, poses: np.ndarray, rows: np.ndarray | None = None) -> None:
        """Raise a one-line ValueError naming the first pose (and robot) that is not finite, not
        in the free area, or whose clearance is not above the robot's radius. Poses found valid
        are remembered (the world does not change): a trial's reset at the usual start pose
        skips the polygon and clearance queries."""
        if all(row.tobytes() in self._valid_poses for row in poses):
            return
        who = range(len(poses)) if rows is None else rows
        finite = np.all(np.isfinite(poses), axis=1)
        free = np.zeros(len(poses), dtype=bool)
        free[finite] = self.world.in_free_area(poses[finite, 0], poses[finite, 1])
        clear = np.full(len(poses), -np.inf)
        clear[free] = self.walls.clearance(poses[free, :2])
        bad = np.flatnonzero(~(clear > self.robot.radius))
        if len(bad) == 0:
            if len(self._valid_poses) < 4096:  # bounded: start poses, not random ones
                self._valid_poses.update(row.tobytes() for row in poses)
            return
        i = int(bad[0])
        pose = tuple(float(v) for v in poses[i])
        if not finite[i]:
            why = "is not 3 finite numbers (x, y, heading)"
        elif not free[i]:
            why = f"is not in the free area of map {self.world.name!r}"
        else:
            why = (
                f"is too close to a wall: clearance {clear[i]:.3f} m <= robot radius "
                f"{self.robot.radius} m"
            )
        raise ValueError(f"reset: pose {pose!r} of robot {int(who[i])} {why}")

    # --- reset and step --------------------------------------------------------------------

    def reset(
        self, rows: np.ndarray, poses: np.ndarray, rngs: Sequence[np.random.Generator]
    ) -> Readings:
        """Put robots ``rows`` (int indices) at ``poses`` ``(k, 3)`` (heading in radians), with
        the odometry at the true pose, and sense. ``rngs`` holds one generator per robot of the
        batch (``rngs[b]`` for robot b); robot b draws its sonar noise from it. Returns the
        readings of those rows, in their order."""
        rows = np.asarray(rows, dtype=np.intp).reshape(-1)
        poses = np.asarray(poses, dtype=np.float64)
        if poses.shape != (len(rows), 3):
            raise ValueError(f"reset: poses must have shape ({len(rows)}, 3), got {poses.shape}")
        # on a list: a partial reset restarts a few robots, and np.unique or a reduction on
        # a few elements costs more than Python's min, max and set
        listed = rows.tolist()
        if listed and (min(listed) < 0 or max(listed) >= self.size):
            raise ValueError(f"reset: rows must be in [0, {self.size}), got {listed}")
        if len(set(listed)) != len(listed):
            raise ValueError(f"reset: rows must be distinct, got {listed}")
        self.check_poses(poses, rows)
        x, y = poses[:, 0].copy(), poses[:, 1].copy()
        h = wrap_angle(poses[:, 2])
        near, rim, refl, clear = self.sensors.sense_at(poses, x, y, h, self._ex.shape[1])
        if self._sonar_std > 0.0:
            noise = np.empty((len(rows), self.n_sensors))
            for i, b in enumerate(listed):
                rngs[b].standard_normal(out=noise[i])
            rim = rim + self._sonar_std * noise
        sonar = np.minimum(np.maximum(rim, 0.0), self.robot.sonar_range)

        # copy-on-write: arrays handed out before stay as they were
        for name, value in (
            ("_x", x),
            ("_y", y),
            ("_h", h),
            ("_xo", x),
            ("_yo", y),
            ("_ho", h),
            ("sonar", sonar),
            ("actions_taken", 0),
            ("_ex", near[0]),
            ("_ey", near[1]),
            ("_clear", clear),
        ):
            state = getattr(self, name).copy()
            state[rows] = value
            setattr(self, name, state)

        f1 = self.sensors.f1(sonar, np.zeros(len(rows), dtype=bool))
        angle, goal = goal_direction(self._goal[0], self._goal[1], x, y, h)
        f2 = -np.abs(wrap_angle(h - angle)) / _PI
        no = np.zeros(len(rows), dtype=bool)  # no collision, no goal, no truncation
        return batch_readings(
            self.robot.sonar_range, sonar, refl, x, y, h, x, y, h, f1, f2, no, no, no, no, no, goal
        )

    def step(self, alpha: np.ndarray, rngs: Sequence[np.random.Generator]) -> Readings:
        """Every robot takes one action: rotate by ``alpha[b]`` (radians, clipped to [-pi, pi];
        a non-finite value raises ValueError naming the robot), translate, handle collisions.
        ``rngs[b]`` is robot b's generator. Returns the readings of all B robots."""
        robot = self.robot
        alpha = np.asarray(alpha, dtype=np.float64).reshape(-1)
        if alpha.shape != (self.size,):
            raise ValueError(f"step: need {self.size} actions, one per robot, got {alpha.size}")
        if len(rngs) != self.size:
            raise ValueError(f"step: need {self.size} generators, one per robot, got {len(rngs)}")
        if self.size == 1 and math.isfinite(a := float(alpha[0])):
            return self._step_one(a, rngs[0])
        if not np.isfinite(alpha).all():
            b = int(np.argmin(np.isfinite(alpha)))
            raise ValueError(f"step: the action of robot {b} must be finite, got {float(alpha[b])}")
        alpha = np.minimum(np.maximum(alpha, -_PI), _PI)
        x0, y0, h0 = self._x, self._y, self._h
        rot_err: np.ndarray | float
        trans_err: np.ndarray | float
        if self._noisy:  # one draw per robot and step: rotation, translation, the n sonars
            z = np.empty((self.size, self.n_sensors + 2))
            for b, rng in enumerate(rngs):
                rng.standard_normal(out=z[b])
            rot_err, trans_err = self._rot_std * z[:, 0], self._trans_std * z[:, 1]
        else:
            z = None
            rot_err = trans_err = 0.0
        h1 = wrap_angle(h0 + alpha + rot_err)
        length = robot.step + trans_err
        x1 = x0 + length * np.cos(h1)
        y1 = y0 + length * np.sin(h1)
        x1, y1, near, real, virtual, collision, stuck = self._collide_many(x0, y0, x1, y1, length)
        rim, refl, clear = self.sensors.sense(x1, y1, h1, near)
        self._x, self._y, self._h = x1, y1, h1
        self._ex, self._ey, self._clear = near[0], near[1], clear
        xo, yo, ho = self._odometry_many(alpha, x1, y1, h1, collision, stuck)
        self.actions_taken = self.actions_taken + 1

        if z is not None and self._sonar_std > 0.0:
            rim = rim + self._sonar_std * z[:, 2:]
        sonar = np.minimum(np.maximum(rim, 0.0), robot.sonar_range)
        self.sonar = sonar
        f1 = self.sensors.f1(sonar, collision)
        gx, gy, gr = self._goal
        angle, goal = goal_direction(gx, gy, xo, yo, ho)
        f2 = -np.abs(wrap_angle(ho - angle)) / _PI
        reached = math_map(math.hypot, x1 - gx, y1 - gy) <= gr
        truncated = ~reached & (self.actions_taken >= self.max_actions)
        return batch_readings(
            robot.sonar_range,
            sonar,
            refl,
            xo,
            yo,
            ho,
            x1,
            y1,
            h1,
            f1,
            f2,
            collision,
            real,
            virtual,
            reached,
            truncated,
            goal,
        )

    def _collide_many(
        self,
        x0: np.ndarray,
        y0: np.ndarray,
        x1: np.ndarray,
        y1: np.ndarray,
        length: np.ndarray | float,
    ) -> tuple[
        np.ndarray,
        np.ndarray,
        tuple[np.ndarray, np.ndarray, np.ndarray],
        np.ndarray,
        np.ndarray,
        np.ndarray,
        bool,
    ]:
        """The collision test of the moves ``(x0, y0) -> (x1, y1)`` and the emergency handler:
        the end points (the start where the move collided), ``Walls.closest_many`` there, the
        real, virtual and any collisions, and whether any robot collided.

        The test goes from the clearance at the end of the move: real = the swept disc touches
        a wall (impossible while the clearance exceeds radius + translation), virtual = an IR
        reflectance > threshold, i.e. a rim distance below 0.056 m (the IR sectors tile the
        ring, so the smallest IR distance is exactly the clearance)."""
        robot = self.robot
        ex, ey, clear = self.walls.closest_many(x1, y1)
        maybe = self._clear <= robot.radius + np.abs(length) + 1e-9
        if maybe.any():
            m = maybe.nonzero()[0]
            real = np.zeros(self.size, dtype=bool)
            real[m] = self.walls.swept_disc_contact_many(
                x0[m], y0[m], x1[m], y1[m], robot.radius, self._clear[m], clear[m]
            )
        else:
            real = maybe
        close = clear < self._virtual_reach
        if close.any():
            d = np.minimum(np.maximum(clear - robot.radius, 0.0), robot.ir_range)
            reflectance = 100.0 * math_map(pow, 1.0 - d / robot.ir_range, 3.0)
            virtual = ~real & (reflectance > robot.ir_collision_threshold)
            collision = real | virtual
        else:
            virtual = close
            collision = real
        stuck = bool(collision.any())
        if stuck:  # emergency handler: back to the pose before the translation
            x1 = np.where(collision, x0, x1)
            y1 = np.where(collision, y0, y1)
            back = collision[:, None]
            ex = np.where(back, self._ex, ex)
            ey = np.where(back, self._ey, ey)
            clear = np.where(collision, self._clear, clear)
        return x1, y1, (ex, ey, clear), real, virtual, collision, stuck

    def _odometry_many(
        self,
        alpha: np.ndarray,
        x1: np.ndarray,
        y1: np.ndarray,
        h1: np.ndarray,
        collision: np.ndarray,
        stuck: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The odometry after the actions ``alpha`` (``stuck``: some robot collided), stored."""
        robot = self.robot
        if robot.perfect_odometry:
            xo, yo, ho = x1, y1, h1
        else:
            xo, yo, ho = self._xo, self._yo, wrap_angle(self._ho + alpha)
            if not (stuck and collision.all()):  # a collision reverses its translation too
                moved_x = xo + robot.step * np.cos(ho)
                moved_y = yo + robot.step * np.sin(ho)
                xo = np.where(collision, xo, moved_x) if stuck else moved_x
                yo = np.where(collision, yo, moved_y) if stuck else moved_y
        self._xo, self._yo, self._ho = xo, yo, ho
        return xo, yo, ho

    def _step_one(self, alpha: float, rng: np.random.Generator) -> Readings:
        """:meth:`step` for a batch of one, on Python floats: the same operations in the same
        order (IEEE arithmetic and the C library's cos, sin, atan2, hypot, pow, as the array
        lane), without numpy's per-call overhead, which dominates a single robot's step. The
        B-invariance tests hold the two lanes bitwise equal (a batch of one against a robot
        inside a larger batch)."""
        robot = self.robot
        alpha = -_PI if alpha < -_PI else (_PI if alpha > _PI else alpha)
        x0, y0, h0 = float(self._x[0]), float(self._y[0]), float(self._h[0])
        clear0 = float(self._clear[0])
        if self._noisy:  # one draw per step: rotation, translation, then the n sonars
            z = rng.standard_normal(self.n_sensors + 2)
            rot_err, trans_err = self._rot_std * float(z[0]), self._trans_std * float(z[1])
        else:
            z = None
            rot_err = trans_err = 0.0
        h1 = (h0 + alpha + rot_err + _PI) % _TWO_PI - _PI
        length = robot.step + trans_err
        x1 = x0 + length * math.cos(h1)
        y1 = y0 + length * math.sin(h1)

        near = self.walls.closest(x1, y1)
        real, virtual = self._collide_one(x0, y0, x1, y1, length, clear0, near[2])
        collision = real or virtual
        if collision:  # emergency handler: back to the pose before the translation
            x1, y1 = x0, y0
            near = (self._ex[0], self._ey[0], clear0)
        rim, refl, clear = self.sensors.sense_one(x1, y1, h1, near)
        self._x[0], self._y[0], self._h[0] = x1, y1, h1  # private, never handed out
        self._ex, self._ey, self._clear[0] = near[0][None], near[1][None], clear

        if robot.perfect_odometry:
            xo, yo, ho = x1, y1, h1
        else:
            xo, yo = float(self._xo[0]), float(self._yo[0])
            ho = (float(self._ho[0]) + alpha + _PI) % _TWO_PI - _PI
            if not collision:
                xo = xo + robot.step * math.cos(ho)
                yo = yo + robot.step * math.sin(ho)
        self._xo[0], self._yo[0], self._ho[0] = xo, yo, ho
        self.actions_taken = self.actions_taken + 1

        if z is not None and self._sonar_std > 0.0:
            rim = rim + self._sonar_std * z[2:]
        sonar = np.minimum(np.maximum(rim, 0.0), robot.sonar_range)
        self.sonar = sonar
        if collision:
            f1 = -3.0
        else:
            dmin = float(sonar.min())
            close = robot.close_distance
            f1 = -1.0 + dmin / close if dmin < close else 0.0
        gx, gy, gr = self._goal
        dx, dy = gx - xo, gy - yo
        angle = math.atan2(dy, dx)
        f2 = -abs((ho - angle + _PI) % _TWO_PI - _PI) / _PI
        reached = math.hypot(x1 - gx, y1 - gy) <= gr
        truncated = not reached and int(self.actions_taken[0]) >= self.max_actions
        goal = (math.hypot(dx, dy), (angle - ho + _PI) % _TWO_PI - _PI)
        flags = (collision, real, virtual, reached, truncated)
        return one_readings(
            robot.sonar_range, sonar, refl, (xo, yo, ho), goal, (x1, y1, h1), f1, f2, flags
        )

    def _collide_one(
        self, x0: float, y0: float, x1: float, y1: float, length: float, clear0: float, clear: float
    ) -> tuple[bool, bool]:
        """:meth:`_collide_many`'s test for one robot on floats: real and virtual collision."""
        robot = self.robot
        real = clear0 <= robot.radius + abs(length) + 1e-9 and self.walls.swept_disc_contact(
            x0, y0, x1, y1, robot.radius, clear0, clear
        )
        virtual = False
        if not real and clear < self._virtual_reach:
            d = min(max(clear - robot.radius, 0.0), robot.ir_range)
            virtual = 100.0 * (1.0 - d / robot.ir_range) ** 3 > robot.ir_collision_threshold
        return real, virtual
