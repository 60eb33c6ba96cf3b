"""Angle and goal arithmetic that rounds the same for every robot of a batch.

Angle wrapping with the same operations as Python's float ``%``, and the functions whose numpy
SIMD loops round differently from the C library (atan2, hypot, pow) applied element-wise through
``math``, as the original scalar model did: a robot's numbers never depend on its place in a
batch (:mod:`symrl.world.physics`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from itertools import repeat

import numpy as np

__all__ = ["PI", "TWO_PI", "goal_direction", "goal_reading", "math_map", "wrap_angle"]

PI = math.pi
TWO_PI = 2.0 * math.pi


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Wrap angles to [-pi, pi] (the same operations as Python's float ``%``)."""
    return np.mod(angle + PI, TWO_PI) - PI


def goal_reading(
    goal_x: float, goal_y: float, x: np.ndarray, y: np.ndarray, h: np.ndarray
) -> np.ndarray:
    """(k, 2) float32: distance and signed angle (left +) to the goal from poses (x, y, h), the
    observation's ``goal``. The C library's hypot and atan2 per element: numpy's SIMD loops
    round differently in the body and the tail of an array, so a robot's numbers would depend
    on its place in a batch."""
    return goal_direction(goal_x, goal_y, x, y, h)[1]


def goal_direction(
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


def math_map(fn: Callable[..., float], a: np.ndarray, b: np.ndarray | float) -> np.ndarray:
    """``fn(a, b)`` element-wise with the C library's ``fn`` (``math.atan2``, ``math.hypot``,
    ``pow``): numpy's SIMD versions differ in the last bit, and the scalar ones define the model."""
    second = b.tolist() if isinstance(b, np.ndarray) else repeat(b)
    return np.fromiter(map(fn, a.tolist(), second), np.float64, count=len(a))
