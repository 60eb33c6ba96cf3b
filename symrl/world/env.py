"""The Gymnasium env of Hailu (2001): a B21 robot drives from a room through a door to a goal."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap, load_map

__all__ = ["Hailu2001Env"]

_PI = math.pi
_TWO_PI = 2.0 * math.pi


def _wrap(angle: float) -> float:
    """Wrap an angle to [-pi, pi]."""
    return (angle + _PI) % _TWO_PI - _PI


class Hailu2001Env(gymnasium.Env):
    """
    ## Description

    A cylindrical B21 robot (a disc of radius 0.26 m) learns a short, safe path from a start pose
    in a 25 m^2 room, through a 1 m door in a 0.25 m thick dividing wall, to a goal circle in a
    1.8 m wide corridor (Hailu 2001, Fig. 2). Each action is a rotation followed by a fixed 0.20 m
    translation. The robot senses the walls with 24 sonars (its view of the world), 24 IR sensors
    and a bumper (used to detect real and virtual collisions), and believes its pose from
    odometry, which drifts from the true pose because the true motion is noisy.

    The world is data: `map` names a built-in map, a YAML map file, or a `WorldMap` (walls as
    polygons or segments, start, goal and the region rules of the paper's symbolic partition).

    ## Observation Space

    A `Dict` of `float32` arrays (n = `robot.n_sensors`, 24 by default):

    | key          | shape | range            | meaning                                          |
    |--------------|-------|------------------|--------------------------------------------------|
    | `"sonar"`    | (n,)  | [0, 1]           | rim distance along ray k / 5.0 m (k=0 ahead, CCW) |
    | `"ir"`       | (n,)  | [0, 100]         | reflectance of the nearest wall in sector k      |
    | `"bumper"`   | (1,)  | {0, 1}           | 1 if the body touched a wall during this step    |
    | `"odometry"` | (3,)  | see below        | x, y, heading in [-pi, pi] the robot believes    |
    | `"goal"`     | (2,)  | see below        | distance, signed angle (left +) to the goal      |

    Sonar k reads the distance from the body's rim to the first wall along the ray from the centre,
    capped at 5.0 m, plus Gaussian noise (std 0.01 m), clipped to [0, 5]. IR sensor k reads the rim
    distance d of the nearest wall point whose bearing from the centre is within +-7.5 deg of its
    axis, so the 24 sectors tile the ring and min_k d is the exact clearance; the reflectance is
    100*(1 - d/0.5)^3 for d < 0.5 m, else 0. The odometry x, y lie in the map's bounding box
    widened by `max_actions * step` (40 m: the furthest the odometry can travel in a trial), the
    goal distance in [0, diagonal of that box], angles in [-pi, pi].

    ## Action Space

    `Box(-pi, pi, (1,), float32)`: the rotation alpha (radians, counter-clockwise) applied before
    the 0.20 m translation. Values outside are clipped; a non-finite action raises `ValueError`.

    ## Transition Dynamics

    1. Rotate by alpha; the true rotation gets Gaussian noise (std 0.5 deg).
    2. Translate forward l = 0.20 m; the true translation gets Gaussian noise (std 1% of l).
       The odometry pose moves exactly as commanded (or equals the true pose with
       `robot.perfect_odometry`).
    3. If the swept disc touches a wall (real collision, bumper = 1), or any IR reflectance after
       the move exceeds 70 (virtual collision, rim distance < 0.056 m), the emergency handler
       reverses the robot (and its odometry) to the pose before the translation; the heading
       keeps the rotation. The true pose is never inside a wall.

    ## Reward

    r = f1 + f2 (Eqs. 3 and 4). f1 = -3 on a collision; otherwise -1 + min_j(d_j / d_c) if the
    smallest sensed sonar rim distance d_j is below d_c = 0.30 m; otherwise 0.
    f2 = -acute(|theta_h - theta_gr|) / pi, with theta_h the odometry heading after the action and
    theta_gr the direction from the odometry position to the goal. Every reward is in [-4, 0].

    ## Starting State

    The map's start pose, (0, 0) heading 0 for `hailu2001`; or any free pose passed as
    `reset(options={"pose": (x, y, heading)})`. The odometry starts at the true pose.

    ## Episode End

    - Termination: the TRUE centre is within the goal radius (0.40 m) of the goal (4.0, -2.0).
    - Truncation: `max_actions` (200) actions without reaching the goal (a failed trial).

    ## Arguments

    ```python
    import gymnasium, symrl
    env = gymnasium.make("symrl/Hailu2001-v0", map="hailu2001", noise=True,
                         robot={"sonar_cone_deg": 25.0}, max_actions=200, render_mode=None)
    ```

    - `map`: built-in map name, path of a YAML map file, or a `WorldMap`.
    - `noise`: `False` turns every noise source off (sonar, rotation, translation).
    - `robot`: a `RobotConfig` or a dict of its fields (radius, sensors, noise levels, ...).
    - `max_actions`: actions per trial before truncation.
    - `render_mode`: `None`, `"human"` (a matplotlib window) or `"rgb_array"` (HWC uint8).

    `info` holds `true_pose` (3,) float64, `collision`, `real_collision`, `virtual_collision`,
    `reached_goal` (np.bool_), `f1`, `f2` (np.float64). `real_collision` is swept-disc contact;
    `virtual_collision` is an IR reflectance above 70 after a move that made no contact. After
    `reset` the flags are False and `f1 = f2 = 0`.

    Attributes: `world` (`WorldMap`), `robot` (`RobotConfig`), `true_pose` and `odometry_pose`
    ((3,) float64), `path` and `odometry_path` (lists of (x, y) since the reset, start included),
    `actions_taken`; `sense(x, y, heading)` gives the noise-free sonar rim distances and IR
    reflectances at any pose and `clearance(x, y)` the distance to the nearest wall.

    ## Version History

    - v0: initial version (symrl 0.1.0). Randomness: per step one standard-normal draw of
      n + 2 values from `self.np_random` (rotation, translation, the n sonars).

    ## References

    G. Hailu, "Symbolic structures in numeric reinforcement for learning optimum robot
    trajectory", Robotics and Autonomous Systems 37 (2001) 53-68.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self,
        map: str | Path | WorldMap | dict[str, Any] = "hailu2001",
        noise: bool = True,
        render_mode: str | None = None,
        robot: RobotConfig | dict[str, Any] | None = None,
        max_actions: int = 200,
    ) -> None:
        self.world: WorldMap = map if isinstance(map, WorldMap) else load_map(map)
        if robot is None:
            robot = RobotConfig()
        elif isinstance(robot, dict):
            robot = RobotConfig.from_dict(robot)
        elif not isinstance(robot, RobotConfig):
            raise ValueError(f"robot must be a RobotConfig or a dict of its fields, got {robot!r}")
        self.robot: RobotConfig = robot
        if not isinstance(noise, (bool, np.bool_)):
            raise ValueError(f"noise must be True or False, got {noise!r}")
        self.noise = bool(noise)
        if isinstance(max_actions, bool) or not isinstance(max_actions, int) or max_actions < 1:
            raise ValueError(f"max_actions must be a positive integer, got {max_actions!r}")
        self.max_actions = max_actions
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode

        n = robot.n_sensors
        self.action_space = spaces.Box(-np.pi, np.pi, (1,), np.float32)
        # the odometry moves at most `step` per action, so within a trial it stays this close
        # to the map (finite bounds, so spaces can be sampled and checked)
        reach = max_actions * robot.step
        xmin, xmax, ymin, ymax = self.world.bounds
        far = math.hypot(xmax - xmin, ymax - ymin) + 2.0 * reach
        self.observation_space = spaces.Dict(
            {
                "sonar": spaces.Box(0.0, 1.0, (n,), np.float32),
                "ir": spaces.Box(0.0, 100.0, (n,), np.float32),
                "bumper": spaces.Box(0.0, 1.0, (1,), np.float32),
                "odometry": spaces.Box(
                    np.array([xmin - reach, ymin - reach, -np.pi], np.float32),
                    np.array([xmax + reach, ymax + reach, np.pi], np.float32),
                    dtype=np.float32,
                ),
                "goal": spaces.Box(
                    np.array([0.0, -np.pi], np.float32),
                    np.array([far, np.pi], np.float32),
                    dtype=np.float32,
                ),
            }
        )

        # --- precomputed constants of the per-step model --------------------------------
        self._walls = Walls(self.world.segments)
        self._n = n
        axes = (_TWO_PI / n) * np.arange(n)
        if robot.sonar_cone_deg > 0.0:
            m = robot.sonar_cone_rays
            half = 0.5 * math.radians(robot.sonar_cone_deg)
            sub = np.linspace(-half, half, m) if m > 1 else np.zeros(1)
            sonar_offsets = (axes[:, None] + sub[None, :]).ravel()
        else:
            m = 1
            sonar_offsets = axes
        self._cone_rays = m
        self._sonar_offsets = sonar_offsets
        self._cast_range = robot.radius + robot.sonar_range
        self._ir_zero = np.zeros(n)
        self._ir_reach = robot.radius + robot.ir_range
        self._sonar_std = robot.sonar_noise_std if self.noise else 0.0
        self._rot_std = math.radians(robot.rotation_noise_deg) if self.noise else 0.0
        self._trans_std = robot.translation_noise * robot.step if self.noise else 0.0
        self._noisy = self._sonar_std > 0 or self._rot_std > 0 or self._trans_std > 0
        self._goal = (self.world.goal.x, self.world.goal.y, self.world.goal.radius)

        # --- state ----------------------------------------------------------------------
        self._true = (self.world.start.x, self.world.start.y, _wrap(self.world.start.heading))
        self._odom = self._true
        self._clear = math.inf  # true clearance of the current pose (for the swept-test skip)
        self._near: Any = None  # Walls.closest at the current true pose
        self._actions = 0
        self.path: list[tuple[float, float]] = []
        self.odometry_path: list[tuple[float, float]] = []
        self._last_sonar: np.ndarray | None = None
        self._renderer: Any = None

    # --- public state ----------------------------------------------------------------------

    @property
    def true_pose(self) -> np.ndarray:
        """The true pose (x, y, heading), heading wrapped to [-pi, pi]."""
        return np.array(self._true, dtype=np.float64)

    @property
    def odometry_pose(self) -> np.ndarray:
        """The pose the robot believes (x, y, heading)."""
        return np.array(self._odom, dtype=np.float64)

    @property
    def actions_taken(self) -> int:
        """Actions taken since the last reset."""
        return self._actions

    def sense(self, x: float, y: float, heading: float) -> tuple[np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances (metres) and IR reflectances at any pose (no state
        change): for planners, figures and benchmarks."""
        rim, refl, _ = self._sense(float(x), float(y), float(heading))
        return rim.copy(), refl.copy()

    def clearance(self, x: float, y: float) -> float:
        """Distance from the point to the nearest wall (the robot's centre clearance there)."""
        return float(self._walls.clearance(np.array([x, y], dtype=np.float64)))

    # --- gymnasium API ---------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        start = self.world.start
        pose: Any = (start.x, start.y, start.heading)
        if options is not None:
            if not isinstance(options, dict):
                raise ValueError(f"options must be a dict, got {options!r}")
            unknown = set(options) - {"pose"}
            if unknown:
                raise ValueError(f"reset: unknown option(s) {sorted(unknown)}; allowed: ['pose']")
            if options.get("pose") is not None:
                pose = options["pose"]
        x, y, h = self._check_pose(pose)
        self._true = (x, y, h)
        self._odom = self._true
        self._actions = 0
        self.path = [(x, y)]
        self.odometry_path = [(x, y)]
        self._near = self._walls.closest(x, y)
        rim, refl, clear = self._sense(x, y, h, self._near)
        self._clear = clear
        noise = self.np_random.standard_normal(self._n) if self._sonar_std > 0.0 else None
        sonar = self._noisy_sonar(rim, noise)
        info = self._info(False, False, 0.0, 0.0, False)
        obs = self._observation(sonar, refl, False)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        alpha = self._parse_action(action)
        robot = self.robot
        x0, y0, h0 = self._true
        if self._noisy:  # one draw per step: rotation, translation, then the n sonars
            z = self.np_random.standard_normal(self._n + 2)
            rot_err, trans_err = self._rot_std * float(z[0]), self._trans_std * float(z[1])
        else:
            z = None
            rot_err = trans_err = 0.0
        h1 = _wrap(h0 + alpha + rot_err)
        length = robot.step + trans_err
        x1 = x0 + length * math.cos(h1)
        y1 = y0 + length * math.sin(h1)

        # collision test from the clearance at the end of the move: real = the swept disc
        # touches a wall (impossible while the clearance exceeds radius + translation),
        # virtual = an IR reflectance > 70, i.e. a rim distance below 0.056 m (the IR sectors
        # tile the ring, so the smallest IR distance is exactly the clearance)
        near = self._walls.closest(x1, y1)
        clear = near[2]
        real = self._clear <= robot.radius + abs(length) + 1e-9 and (
            self._walls.swept_disc_contact(x0, y0, x1, y1, robot.radius, self._clear, clear)
        )
        d = min(max(clear - robot.radius, 0.0), robot.ir_range)
        reflectance = 100.0 * (1.0 - d / robot.ir_range) ** 3
        virtual = not real and reflectance > robot.ir_collision_threshold
        collision = real or virtual
        if collision:  # emergency handler: back to the pose before the translation
            x1, y1 = x0, y0
            near = self._near
        rim, refl, clear = self._sense(x1, y1, h1, near)
        self._true = (x1, y1, h1)
        self._clear = clear
        self._near = near

        if robot.perfect_odometry:
            self._odom = self._true
        else:
            xo, yo, ho = self._odom
            ho = _wrap(ho + alpha)
            if not collision:
                xo += robot.step * math.cos(ho)
                yo += robot.step * math.sin(ho)
            self._odom = (xo, yo, ho)
        self._actions += 1
        self.path.append((x1, y1))
        self.odometry_path.append(self._odom[:2])

        sonar = self._noisy_sonar(rim, None if z is None else z[2:])
        if collision:
            f1 = -3.0
        else:
            dmin = float(sonar.min())
            f1 = -1.0 + dmin / robot.close_distance if dmin < robot.close_distance else 0.0
        xo, yo, ho = self._odom
        gx, gy, gr = self._goal
        f2 = -abs(_wrap(ho - math.atan2(gy - yo, gx - xo))) / _PI
        reached = math.hypot(x1 - gx, y1 - gy) <= gr
        truncated = not reached and self._actions >= self.max_actions
        obs = self._observation(sonar, refl, real)
        info = self._info(collision, real, f1, f2, reached, virtual)
        if self.render_mode == "human":
            self.render()
        return obs, f1 + f2, reached, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human'"
            )
            return None
        from symrl.world.render import EnvRenderer

        if self._renderer is None:
            self._renderer = EnvRenderer(self.world, self.robot, human=self.render_mode == "human")
        sonar = self._last_sonar if self._last_sonar is not None else np.zeros(self._n)
        frame = self._renderer.draw(self.true_pose, sonar, self.path, self.odometry_path)
        return frame if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # matplotlib figures do not pickle
        return state

    # --- internals -------------------------------------------------------------------------

    def _check_pose(self, pose: Any) -> tuple[float, float, float]:
        try:
            values = [float(v) for v in pose]
        except (TypeError, ValueError):
            raise ValueError(f"reset: pose must be (x, y, heading), got {pose!r}") from None
        if len(values) == 2:
            values.append(0.0)
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"reset: pose must be 3 finite numbers (x, y, heading), got {pose!r}")
        x, y, h = values
        if not bool(self.world.in_free_area(x, y)):
            raise ValueError(
                f"reset: pose {pose!r} is not in the free area of map {self.world.name!r}"
            )
        clear = self.clearance(x, y)
        if clear <= self.robot.radius:
            raise ValueError(
                f"reset: pose {pose!r} is too close to a wall: clearance {clear:.3f} m "
                f"<= robot radius {self.robot.radius} m"
            )
        return x, y, _wrap(h)

    def _parse_action(self, action: Any) -> float:
        arr = np.asarray(action, dtype=np.float64)
        if arr.size != 1:
            raise ValueError(f"action must be a single rotation angle, got {action!r}")
        alpha = arr.item()
        if not math.isfinite(alpha):
            raise ValueError(f"action must be finite, got {action!r}")
        return -_PI if alpha < -_PI else (_PI if alpha > _PI else alpha)

    def _sense(
        self, x: float, y: float, h: float, near: Any = None
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """Noise-free sonar rim distances, IR reflectances and the true clearance at a pose
        (``near``: ``Walls.closest`` at this point, if already computed)."""
        robot = self.robot
        rays, sectors, clear = self._walls.scan(
            x, y, h, self._sonar_offsets, self._n, self._cast_range, self._ir_reach, near
        )
        if self._cone_rays > 1:
            rays = np.minimum.reduce(rays.reshape(self._n, self._cone_rays), axis=1)
        rim = np.minimum(rays - robot.radius, robot.sonar_range)
        if sectors is None:  # nothing within IR range
            return rim, self._ir_zero, clear
        return rim, self._reflectance(sectors - robot.radius), clear

    def _reflectance(self, rim_distance: Any) -> Any:
        """100 * (1 - d / ir_range)^3, d clipped to [0, ir_range] (scalar or array)."""
        r = self.robot.ir_range
        d = np.minimum(np.maximum(rim_distance, 0.0), r)
        return 100.0 * (1.0 - d * (1.0 / r)) ** 3

    def _noisy_sonar(self, rim: np.ndarray, noise: np.ndarray | None) -> np.ndarray:
        """Add ``sonar_noise_std`` times the standard normal ``noise`` and clip to the range."""
        if noise is not None and self._sonar_std > 0.0:
            rim = rim + self._sonar_std * noise
        sonar = np.minimum(np.maximum(rim, 0.0), self.robot.sonar_range)
        self._last_sonar = sonar
        return sonar

    def _observation(
        self, sonar: np.ndarray, refl: np.ndarray, bumper: bool
    ) -> dict[str, np.ndarray]:
        xo, yo, ho = self._odom
        gx, gy, _ = self._goal
        dx, dy = gx - xo, gy - yo
        return {
            "sonar": (sonar * (1.0 / self.robot.sonar_range)).astype(np.float32),
            "ir": refl.astype(np.float32),
            "bumper": np.array([1.0 if bumper else 0.0], dtype=np.float32),
            "odometry": np.array([xo, yo, ho], dtype=np.float32),
            "goal": np.array(
                [math.hypot(dx, dy), _wrap(math.atan2(dy, dx) - ho)], dtype=np.float32
            ),
        }

    def _info(
        self,
        collision: bool,
        real: bool,
        f1: float,
        f2: float,
        reached: bool,
        virtual: bool = False,
    ) -> dict[str, Any]:
        return {
            "true_pose": np.array(self._true, dtype=np.float64),
            "collision": np.bool_(collision),
            "real_collision": np.bool_(real),
            "virtual_collision": np.bool_(virtual),
            "f1": np.float64(f1),
            "f2": np.float64(f2),
            "reached_goal": np.bool_(reached),
        }
