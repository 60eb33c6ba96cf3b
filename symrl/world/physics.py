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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from itertools import repeat
from typing import NamedTuple

import numpy as np

from symrl.world.robot import RobotConfig
from symrl.world.spatial import walls_for
from symrl.world.worldmap import WorldMap

__all__ = ["Readings", "RobotBatch", "goal_reading", "wrap_angle"]

_PI = math.pi
_TWO_PI = 2.0 * math.pi


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap angles to [-pi, pi] (the same operations as Python's float ``%``)."""
    return np.mod(angle + _PI, _TWO_PI) - _PI


def goal_reading(
    goal_x: float, goal_y: float, x: np.ndarray, y: np.ndarray, h: np.ndarray
) -> np.ndarray:
    """(k, 2) float32: distance and signed angle (left +) to the goal from poses (x, y, h), the
    observation's ``goal``. The C library's hypot and atan2 per element: numpy's SIMD loops
    round differently in the body and the tail of an array, so a robot's numbers would depend
    on its place in a batch."""
    return _goal_direction(goal_x, goal_y, x, y, h)[1]


def _goal_direction(
    goal_x: float, goal_y: float, x: np.ndarray, y: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The direction from (x, y) to the goal and :func:`goal_reading` at (x, y, h): the physics
    needs both (the reward's f2 and the observation), from the same offsets."""
    dx, dy = (goal_x - x).tolist(), (goal_y - y).tolist()  # once, for both functions
    angle = np.fromiter(map(math.atan2, dy, dx), np.float64, count=len(dx))
    out = np.empty((len(dx), 2), np.float32)
    out[:, 0] = np.fromiter(map(math.hypot, dx, dy), np.float64, count=len(dx))
    out[:, 1] = wrap_angle(angle - h)
    return angle, out


def _math_map(fn: Callable[..., float], a: np.ndarray, b: np.ndarray | float) -> np.ndarray:
    """``fn(a, b)`` element-wise with the C library's ``fn`` (``math.atan2``, ``math.hypot``,
    ``pow``): numpy's SIMD versions differ in the last bit, and the scalar ones define the model."""
    second = b.tolist() if isinstance(b, np.ndarray) else repeat(b)
    return np.fromiter(map(fn, a.tolist(), second), np.float64, count=len(a))


def _columns(x: np.ndarray, y: np.ndarray, h: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """A new (k, 3) array of the three columns (cheaper than ``np.stack`` at small k)."""
    out: np.ndarray = np.empty((len(x), 3), dtype)
    out[:, 0] = x
    out[:, 1] = y
    out[:, 2] = h
    return out


class Readings(NamedTuple):
    """What the robots of one reset or step report, one row per robot concerned.

    Observation arrays are float32 (ready for the spaces/specs); the rest float64 or bool.
    After a reset, ``reward``/``f1``/``f2`` are the reinforcement of the reset state (f1 from the
    sonar rule without a collision, f2 from the heading) and every flag is False.
    """

    sonar: np.ndarray
    """(k, n) float32 in [0, 1]: sonar rim distance / sonar_range, noise added and clipped."""
    ir: np.ndarray
    """(k, n) float32 in [0, 100]: IR reflectances."""
    bumper: np.ndarray
    """(k, 1) float32: 1 on a real collision during this step."""
    odometry: np.ndarray
    """(k, 3) float32: the pose the robot believes (x, y, heading)."""
    goal: np.ndarray
    """(k, 2) float32: distance and signed angle (left +) to the goal, from the odometry."""
    reward: np.ndarray
    """(k,) float64: f1 + f2, the reinforcement of the state reached."""
    f1: np.ndarray
    """(k,) float64: -3 on a collision, else -1 + min sonar / d_c near a wall, else 0."""
    f2: np.ndarray
    """(k,) float64: -(acute angle between the odometry heading and the goal) / pi."""
    collision: np.ndarray
    """(k,) bool: real or virtual collision (the move was reversed)."""
    real_collision: np.ndarray
    """(k,) bool: the swept disc touched a wall."""
    virtual_collision: np.ndarray
    """(k,) bool: no contact, but an IR reflectance above the threshold after the move."""
    reached_goal: np.ndarray
    """(k,) bool: the TRUE centre is within the goal radius (termination)."""
    truncated: np.ndarray
    """(k,) bool: ``max_actions`` actions without reaching the goal."""
    true_pose: np.ndarray
    """(k, 3) float64: the true pose (x, y, heading) after the reset or step."""


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
        self._rest_senses: dict[bytes, np.ndarray] = {}  # per reset pose: _sense_at's row

        n = robot.n_sensors
        self.n_sensors = n
        axes = (_TWO_PI / n) * np.arange(n)
        if robot.sonar_cone_deg > 0.0:
            m = robot.sonar_cone_rays
            half = 0.5 * math.radians(robot.sonar_cone_deg)
            sub = np.linspace(-half, half, m) if m > 1 else np.zeros(1)
            self._sonar_offsets: np.ndarray = (axes[:, None] + sub[None, :]).ravel()
        else:
            m = 1
            self._sonar_offsets = axes
        self._cone_rays = m
        self._cast_range = robot.radius + robot.sonar_range
        self._ir_reach = robot.radius + robot.ir_range
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
        return _columns(self._x, self._y, self._h)

    def odometry_xy(self, b: int) -> tuple[float, float]:
        """Robot b's odometry position as floats (for the Gymnasium env's ``odometry_path``)."""
        return float(self._xo[b]), float(self._yo[b])

    @property
    def odometry_pose(self) -> np.ndarray:
        """(B, 3) float64: the poses the robots believe."""
        return _columns(self._xo, self._yo, self._ho)

    # --- spaces --------------------------------------------------------------------------

    def observation_bounds(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """(low, high) float32 per observation key, one robot's shape. The odometry moves at most
        ``step`` per action, so within a trial it stays within ``max_actions * step`` of the map
        (finite bounds, so spaces can be sampled and checked)."""
        n = self.n_sensors
        reach = self.max_actions * self.robot.step
        xmin, xmax, ymin, ymax = self.world.bounds
        far = math.hypot(xmax - xmin, ymax - ymin) + 2.0 * reach
        f32 = np.float32
        return {
            "sonar": (np.zeros(n, f32), np.ones(n, f32)),
            "ir": (np.zeros(n, f32), np.full(n, 100.0, f32)),
            "bumper": (np.zeros(1, f32), np.ones(1, f32)),
            "odometry": (
                np.array([xmin - reach, ymin - reach, -np.pi], f32),
                np.array([xmax + reach, ymax + reach, np.pi], f32),
            ),
            "goal": (np.array([0.0, -np.pi], f32), np.array([far, np.pi], f32)),
        }

    # --- queries ---------------------------------------------------------------------------

    def sense(
        self, x: np.ndarray, y: np.ndarray, heading: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances (metres) and IR reflectances ``(k, n)`` at k poses (no
        state change): for planners, figures and benchmarks."""
        x, y, h = (np.asarray(v, dtype=np.float64).reshape(-1) for v in (x, y, heading))
        rim, refl, _ = self._sense(x, y, h, None)
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
        near, rim, refl, clear = self._sense_at(poses, x, y, h)
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

        f1 = self._f1(sonar, np.zeros(len(rows), dtype=bool))
        angle, goal = _goal_direction(self._goal[0], self._goal[1], x, y, h)
        f2 = -np.abs(wrap_angle(h - angle)) / _PI
        no = np.zeros(len(rows), dtype=bool)  # no collision, no goal, no truncation
        return self._readings(sonar, refl, x, y, h, x, y, h, f1, f2, no, no, no, no, no, goal)

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

        # collision test from the clearance at the end of the move: real = the swept disc
        # touches a wall (impossible while the clearance exceeds radius + translation),
        # virtual = an IR reflectance > threshold, i.e. a rim distance below 0.056 m (the IR
        # sectors tile the ring, so the smallest IR distance is exactly the clearance)
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
            reflectance = 100.0 * _math_map(pow, 1.0 - d / robot.ir_range, 3.0)
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
        rim, refl, clear = self._sense(x1, y1, h1, (ex, ey, clear))
        self._x, self._y, self._h = x1, y1, h1
        self._ex, self._ey, self._clear = ex, ey, clear

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
        self.actions_taken = self.actions_taken + 1

        if z is not None and self._sonar_std > 0.0:
            rim = rim + self._sonar_std * z[:, 2:]
        sonar = np.minimum(np.maximum(rim, 0.0), robot.sonar_range)
        self.sonar = sonar
        f1 = self._f1(sonar, collision)
        gx, gy, gr = self._goal
        angle, goal = _goal_direction(gx, gy, xo, yo, ho)
        f2 = -np.abs(wrap_angle(ho - angle)) / _PI
        reached = _math_map(math.hypot, x1 - gx, y1 - gy) <= gr
        truncated = ~reached & (self.actions_taken >= self.max_actions)
        return self._readings(
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

    def _step_one(self, alpha: float, rng: np.random.Generator) -> Readings:
        """:meth:`step` for a batch of one, on Python floats: the same operations in the same
        order (IEEE arithmetic and the C library's cos, sin, atan2, hypot, pow, as the array
        lane), without numpy's per-call overhead, which dominates a single robot's step. The
        B-invariance tests hold the two lanes bitwise equal (a batch of one against a robot
        inside a larger batch)."""
        robot = self.robot
        walls = self.walls
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

        near = walls.closest(x1, y1)
        clear = near[2]
        real = clear0 <= robot.radius + abs(length) + 1e-9 and walls.swept_disc_contact(
            x0, y0, x1, y1, robot.radius, clear0, clear
        )
        virtual = False
        if not real and clear < self._virtual_reach:
            d = min(max(clear - robot.radius, 0.0), robot.ir_range)
            virtual = 100.0 * (1.0 - d / robot.ir_range) ** 3 > robot.ir_collision_threshold
        collision = real or virtual
        if collision:  # emergency handler: back to the pose before the translation
            x1, y1 = x0, y0
            near = (self._ex[0], self._ey[0], clear0)
        rays, sectors, clear = walls.scan(
            x1, y1, h1, self._sonar_offsets, self.n_sensors, self._cast_range, self._ir_reach, near
        )
        # (the scalar scan gives sectors only within IR range: no row to blank)
        rim, refl = self._rim_refl(rays[None], None if sectors is None else sectors[None], None)
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
        f32 = np.float32
        goal_angle = (angle - ho + _PI) % _TWO_PI - _PI
        # one array per dtype, sliced into the fields (fewer numpy calls)
        obs = np.array([[xo, yo, ho, math.hypot(dx, dy), goal_angle, float(real)]], f32)
        values = np.array([[f1 + f2, f1, f2, x1, y1, h1]])
        flags = np.array([[collision, real, virtual, reached, truncated]])
        return Readings(
            sonar=(sonar * (1.0 / robot.sonar_range)).astype(f32),
            ir=refl.astype(f32),
            bumper=obs[:, 5:6],
            odometry=obs[:, 0:3],
            goal=obs[:, 3:5],
            reward=values[:, 0],
            f1=values[:, 1],
            f2=values[:, 2],
            collision=flags[:, 0],
            real_collision=flags[:, 1],
            virtual_collision=flags[:, 2],
            reached_goal=flags[:, 3],
            truncated=flags[:, 4],
            true_pose=values[:, 3:6],
        )

    # --- internals -------------------------------------------------------------------------

    def _sense_at(
        self, poses: np.ndarray, x: np.ndarray, y: np.ndarray, h: np.ndarray
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], np.ndarray, np.ndarray, np.ndarray]:
        """``Walls.closest_many`` and the noise-free :meth:`_sense` at reset poses ``(k, 3)``
        (``x``, ``y``, ``h``: their columns, the heading wrapped). They depend on the pose alone
        and every robot computes the same numbers whatever the batch, so each pose's row is
        remembered (bounded: start poses, not random ones) and a trial's reset at a known start
        skips the closest-point and ray queries (about 40 % of a reset)."""
        keys = [row.tobytes() for row in poses]
        rows = [self._rest_senses.get(key) for key in keys]
        n, m = self._ex.shape[1], self.n_sensors  # the closest points' width per robot
        if all(row is not None for row in rows):
            block = np.stack(rows)  # type: ignore[arg-type]
            return (
                (block[:, :n], block[:, n : 2 * n], block[:, -1]),
                block[:, 2 * n : 2 * n + m],
                block[:, 2 * n + m : -1],
                block[:, -1],
            )
        near = self.walls.closest_many(x, y)
        rim, refl, clear = self._sense(x, y, h, near)
        if len(self._rest_senses) < 1024:
            for i, key in enumerate(keys):
                self._rest_senses[key] = np.concatenate(
                    (near[0][i], near[1][i], rim[i], refl[i], clear[i : i + 1])
                )
        return near, rim, refl, clear

    def _sense(
        self,
        x: np.ndarray,
        y: np.ndarray,
        h: np.ndarray,
        near: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances, IR reflectances ``(k, n)`` and true clearances ``(k,)``
        at k poses (``near``: ``Walls.closest_many`` there, if already computed)."""
        rays, sectors, clear = self.walls.scan_many(
            x, y, h, self._sonar_offsets, self.n_sensors, self._cast_range, self._ir_reach, near
        )
        rim, refl = self._rim_refl(rays, sectors, clear)
        return rim, refl, clear

    def _rim_refl(
        self, rays: np.ndarray, sectors: np.ndarray | None, clear: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Sonar rim distances (the nearest sub-ray of a cone) and IR reflectances ``(k, n)``
        from the ray distances ``(k, R)``, sector distances ``(k, n)`` and clearances ``(k,)``
        (rows at or beyond IR range read 0; ``None``: no such row)."""
        robot = self.robot
        n = self.n_sensors
        if self._cone_rays > 1:
            rays = np.minimum.reduce(rays.reshape(len(rays), n, self._cone_rays), axis=2)
        rim = np.minimum(rays - robot.radius, robot.sonar_range)
        if sectors is None:  # nothing within IR range of any robot
            return rim, np.zeros((len(rays), n))
        r = robot.ir_range
        d = np.minimum(np.maximum(sectors - robot.radius, 0.0), r)
        refl = 100.0 * (1.0 - d * (1.0 / r)) ** 3
        if clear is not None:
            refl[clear >= self._ir_reach] = 0.0  # rows with nothing within IR range read 0
        return rim, refl

    def _f1(self, sonar: np.ndarray, collision: np.ndarray) -> np.ndarray:
        """Eq. 3: -3 on a collision, -1 + d_min / d_c if the nearest sonar reading is below d_c."""
        close = self.robot.close_distance
        dmin = np.minimum.reduce(sonar, axis=1)
        f1 = np.where(dmin < close, -1.0 + dmin / close, 0.0)
        if collision.any():
            f1[collision] = -3.0
        return f1

    def _readings(
        self,
        sonar: np.ndarray,
        refl: np.ndarray,
        xo: np.ndarray,
        yo: np.ndarray,
        ho: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        h: np.ndarray,
        f1: np.ndarray,
        f2: np.ndarray,
        collision: np.ndarray,
        real: np.ndarray,
        virtual: np.ndarray,
        reached: np.ndarray,
        truncated: np.ndarray,
        goal: np.ndarray,
    ) -> Readings:
        f32 = np.float32
        return Readings(
            sonar=(sonar * (1.0 / self.robot.sonar_range)).astype(f32),
            ir=refl.astype(f32),
            bumper=real.astype(f32).reshape(-1, 1),  # not [:, None]: torch dislikes stride 0
            odometry=_columns(xo, yo, ho, f32),
            goal=goal,
            reward=f1 + f2,
            f1=f1,
            f2=f2,
            collision=collision,
            real_collision=real,
            virtual_collision=virtual,
            reached_goal=reached,
            truncated=truncated,
            true_pose=_columns(x, y, h),
        )
