"""What the physics reports: the :class:`Readings` of a reset or step, built from its arrays
(B robots) or floats (one robot), and the bounds of the observations in them.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from symrl.world.robot import RobotConfig

__all__ = ["Readings", "batch_readings", "columns", "observation_bounds", "one_readings"]


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


def columns(x: np.ndarray, y: np.ndarray, h: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """A new (k, 3) array of the three columns (cheaper than ``np.stack`` at small k)."""
    out: np.ndarray = np.empty((len(x), 3), dtype)
    out[:, 0] = x
    out[:, 1] = y
    out[:, 2] = h
    return out


def batch_readings(
    sonar_range: float,
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
    """The readings of k robots from their arrays (sonar in metres, up to ``sonar_range``)."""
    f32 = np.float32
    return Readings(
        sonar=(sonar * (1.0 / sonar_range)).astype(f32),
        ir=refl.astype(f32),
        bumper=real.astype(f32).reshape(-1, 1),  # not [:, None]: torch dislikes stride 0
        odometry=columns(xo, yo, ho, f32),
        goal=goal,
        reward=f1 + f2,
        f1=f1,
        f2=f2,
        collision=collision,
        real_collision=real,
        virtual_collision=virtual,
        reached_goal=reached,
        truncated=truncated,
        true_pose=columns(x, y, h),
    )


def one_readings(
    sonar_range: float,
    sonar: np.ndarray,
    refl: np.ndarray,
    odometry: tuple[float, float, float],
    goal: tuple[float, float],
    pose: tuple[float, float, float],
    f1: float,
    f2: float,
    flags: tuple[bool, bool, bool, bool, bool],
) -> Readings:
    """The readings of one robot from floats: ``goal`` (distance, angle), ``flags`` (collision,
    real, virtual, reached, truncated); one array per dtype, sliced into the fields (fewer
    numpy calls)."""
    f32 = np.float32
    obs = np.array([[*odometry, *goal, float(flags[1])]], f32)
    values = np.array([[f1 + f2, f1, f2, *pose]])
    flag_row = np.array([flags])
    return Readings(
        sonar=(sonar * (1.0 / sonar_range)).astype(f32),
        ir=refl.astype(f32),
        bumper=obs[:, 5:6],
        odometry=obs[:, 0:3],
        goal=obs[:, 3:5],
        reward=values[:, 0],
        f1=values[:, 1],
        f2=values[:, 2],
        collision=flag_row[:, 0],
        real_collision=flag_row[:, 1],
        virtual_collision=flag_row[:, 2],
        reached_goal=flag_row[:, 3],
        truncated=flag_row[:, 4],
        true_pose=values[:, 3:6],
    )


def observation_bounds(
    bounds: tuple[float, float, float, float], robot: RobotConfig, max_actions: int
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(low, high) float32 per observation key, one robot's shape, in a map of ``bounds``
    (xmin, xmax, ymin, ymax). The odometry moves at most ``step`` per action, so within a trial
    it stays within ``max_actions * step`` of the map (finite bounds, so spaces can be sampled
    and checked)."""
    n = robot.n_sensors
    reach = max_actions * robot.step
    xmin, xmax, ymin, ymax = bounds
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
