"""The Gymnasium env of Hailu (2001): a B21 robot drives from a room through a door to a goal."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from symrl.world.physics import Readings, RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap, load_map

__all__ = ["Hailu2001Env"]

_PI = math.pi


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
    the 0.20 m translation. An action is a float array (or list of one float) of shape (1,);
    any other shape or dtype (ints, bools, complex, strings) and a non-finite value raise
    `ValueError` naming the action. Finite values outside [-pi, pi] are clipped to it (a turn
    of more than half a revolution is the same turn the other way round, within noise).

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
    - After either, `step` raises `gymnasium.error.ResetNeeded` until `reset` is called; so
      does a `step` before the first `reset` (as under `gymnasium.make`'s order enforcing).
    - After `close`, `reset`, `step` and `render` raise `gymnasium.error.ClosedEnvironmentError`.

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

    The physics is `symrl.world.physics.RobotBatch` with B = 1 (`BatchedWorldEnv`, the TorchRL
    training env, steps B robots with the same model and the same per-robot random streams).

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
        self.robot: RobotConfig = RobotConfig.coerce(robot)
        robot = self.robot
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

        # the physics: a batch of one robot; this env is its Gymnasium face
        self._batch = RobotBatch(self.world, robot, 1, self.noise, max_actions)
        self._n = robot.n_sensors
        self.action_space = spaces.Box(-np.pi, np.pi, (1,), np.float32)
        self.observation_space = spaces.Dict(
            {
                key: spaces.Box(low, high, dtype=np.float32)
                for key, (low, high) in self._batch.observation_bounds().items()
            }
        )
        self._row = np.zeros(1, dtype=np.intp)
        self.path: list[tuple[float, float]] = []
        self.odometry_path: list[tuple[float, float]] = []
        self._sensed = False  # a reading exists (render draws the sonar only after a reset)
        self._ended = True  # no episode runs (none yet, or it ended): step needs a reset
        self._closed = False
        self._renderer: Any = None

    # --- public state ----------------------------------------------------------------------

    @property
    def true_pose(self) -> np.ndarray:
        """The true pose (x, y, heading), heading wrapped to [-pi, pi]."""
        return self._batch.true_pose[0].copy()

    @property
    def odometry_pose(self) -> np.ndarray:
        """The pose the robot believes (x, y, heading)."""
        return self._batch.odometry_pose[0].copy()

    @property
    def actions_taken(self) -> int:
        """Actions taken since the last reset."""
        return int(self._batch.actions_taken[0])

    def sense(self, x: float, y: float, heading: float) -> tuple[np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances (metres) and IR reflectances at any pose (no state
        change): for planners, figures and benchmarks."""
        rim, refl = self._batch.sense(np.array([x]), np.array([y]), np.array([heading]))
        return rim[0], refl[0]

    def clearance(self, x: float, y: float) -> float:
        """Distance from the point to the nearest wall (the robot's centre clearance there)."""
        return float(self._batch.walls.clearance(np.array([x, y], dtype=np.float64)))

    # --- gymnasium API ---------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self._check_open("reset")
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
        r = self._batch.reset(self._row, np.array([[x, y, h]]), (self.np_random,))
        self.path = [(x, y)]
        self.odometry_path = [(x, y)]
        self._sensed = True
        self._ended = False
        # the reset state's reinforcement (r.reward) is the batched env's; here f1 = f2 = 0
        info = self._info(r, False)
        if self.render_mode == "human":
            self.render()
        return self._observation(r), info

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        self._check_open("step")
        if self._ended:
            raise gymnasium.error.ResetNeeded(
                "step() before reset() or after the episode ended (terminated or truncated); "
                "call reset() first"
            )
        alpha = self._parse_action(action)
        r = self._batch.step(np.array([alpha]), (self.np_random,))
        self._ended = bool(r.reached_goal[0] or r.truncated[0])
        x1, y1 = r.true_pose[0, :2].tolist()
        self.path.append((x1, y1))
        self.odometry_path.append(self._batch.odometry_xy(0))
        obs = self._observation(r)
        info = self._info(r, True)
        if self.render_mode == "human":
            self.render()
        return obs, float(r.reward[0]), bool(r.reached_goal[0]), bool(r.truncated[0]), info

    def render(self) -> np.ndarray | None:
        self._check_open("render")
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human'"
            )
            return None
        from symrl.world.render import EnvRenderer

        if self._renderer is None:
            self._renderer = EnvRenderer(self.world, self.robot, human=self.render_mode == "human")
        sonar = self._batch.sonar[0] if self._sensed else np.zeros(self._n)
        frame = self._renderer.draw(self.true_pose, sonar, self.path, self.odometry_path)
        return frame if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self._closed = True

    def _check_open(self, call: str) -> None:
        if self._closed:
            raise gymnasium.error.ClosedEnvironmentError(f"{call}() after close(); make a new env")

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None  # matplotlib figures do not pickle
        return state

    # --- internals -------------------------------------------------------------------------

    def _check_pose(self, pose: Any) -> tuple[float, float, float]:
        try:
            items = list(pose)
        except TypeError:
            raise ValueError(f"reset: pose must be (x, y, heading), got {pose!r}") from None
        if not all(
            isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
            for v in items
        ):
            raise ValueError(f"reset: pose must be numbers (x, y, heading), got {pose!r}")
        values = [float(v) for v in items]
        if len(values) == 2:
            values.append(0.0)
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"reset: pose must be 3 finite numbers (x, y, heading), got {pose!r}")
        x, y, h = values
        if abs(h) > 2 * math.pi:  # larger: almost surely degrees
            raise ValueError(
                f"reset: pose {pose!r}: heading {h:g} is outside +-2*pi; the heading is in "
                "radians (90 degrees is 1.5708)"
            )
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
        return x, y, h  # RobotBatch.reset wraps the heading (once: wrapping twice may round)

    def _parse_action(self, action: Any) -> float:
        try:
            arr = np.asarray(action)
        except (TypeError, ValueError):
            arr = np.asarray(None)
        if arr.dtype.kind != "f" or arr.shape != (1,):
            kind = arr.dtype.name if arr.dtype.kind != "O" else type(action).__name__
            raise ValueError(
                f"action {_show(action)}: expected a float array of shape (1,), the rotation "
                f"in radians (e.g. np.array([0.3], np.float32)), got {kind} of shape {arr.shape}"
            )
        alpha = float(arr[0])
        if not math.isfinite(alpha):
            raise ValueError(f"action {_show(action)}: must be finite")
        return -_PI if alpha < -_PI else (_PI if alpha > _PI else alpha)

    def _observation(self, r: Readings) -> dict[str, np.ndarray]:
        return {
            "sonar": r.sonar[0],
            "ir": r.ir[0],
            "bumper": r.bumper[0],
            "odometry": r.odometry[0],
            "goal": r.goal[0],
        }

    def _info(self, r: Readings, stepped: bool) -> dict[str, Any]:
        """The info dict; after a reset the flags are False and f1 = f2 = 0."""
        return {  # indexing a numpy array gives numpy scalars (np.bool_, np.float64)
            "true_pose": r.true_pose[0],
            "collision": r.collision[0],
            "real_collision": r.real_collision[0],
            "virtual_collision": r.virtual_collision[0],
            "f1": r.f1[0] if stepped else np.float64(0.0),
            "f2": r.f2[0] if stepped else np.float64(0.0),
            "reached_goal": r.reached_goal[0],
        }


def _show(value: Any, limit: int = 60) -> str:
    """``repr`` cut to one short line."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
