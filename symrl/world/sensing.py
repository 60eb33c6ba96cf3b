"""What the robots sense at their poses: sonar rim distances, IR reflectances, clearances, and
the reward's wall term f1 from the sonar.

:class:`Sensors` holds the robot's sensor geometry (the sonar axes and their cone sub-rays, the
sonar and IR reach) and asks a wall-query object (:class:`~symrl.world.geometry.Walls` or
:class:`~symrl.world.spatial.CellWalls`) for the distances, for one pose or B poses at once
(:mod:`symrl.world.physics`).
"""

from __future__ import annotations

import math

import numpy as np

from symrl.world.exact_math import TWO_PI
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig
from symrl.world.spatial import CellWalls

__all__ = ["Sensors"]

Near = tuple[np.ndarray, np.ndarray, np.ndarray]
"""``Walls.closest_many`` at k points: each wall's closest point (relative) and the clearances."""


class Sensors:
    """The sonar and IR ring of a robot, read against ``walls`` (noise-free: the physics adds
    the sonar noise)."""

    def __init__(self, walls: Walls | CellWalls, robot: RobotConfig) -> None:
        self.walls = walls
        self.robot = robot
        n = robot.n_sensors
        self.n_sensors = n
        axes = (TWO_PI / n) * np.arange(n)
        if robot.sonar_cone_deg > 0.0:
            m = robot.sonar_cone_rays
            half = 0.5 * math.radians(robot.sonar_cone_deg)
            sub = np.linspace(-half, half, m) if m > 1 else np.zeros(1)
            self.offsets: np.ndarray = (axes[:, None] + sub[None, :]).ravel()
        else:
            m = 1
            self.offsets = axes
        self.cone_rays = m
        self.cast_range = robot.radius + robot.sonar_range
        self.ir_reach = robot.radius + robot.ir_range
        self._rest: dict[bytes, np.ndarray] = {}  # per reset pose: sense_at's row

    def sense_at(
        self, poses: np.ndarray, x: np.ndarray, y: np.ndarray, h: np.ndarray, width: int
    ) -> tuple[Near, np.ndarray, np.ndarray, np.ndarray]:
        """``Walls.closest_many`` and the noise-free :meth:`sense` at reset poses ``(k, 3)``
        (``x``, ``y``, ``h``: their columns, the heading wrapped; ``width``: the closest points'
        width per robot). They depend on the pose alone and every robot computes the same numbers
        whatever the batch, so each pose's row is remembered (bounded: start poses, not random
        ones) and a trial's reset at a known start skips the closest-point and ray queries
        (about 40 % of a reset)."""
        keys = [row.tobytes() for row in poses]
        rows = [self._rest.get(key) for key in keys]
        n, m = width, self.n_sensors
        if all(row is not None for row in rows):
            block = np.stack(rows)  # type: ignore[arg-type]
            return (
                (block[:, :n], block[:, n : 2 * n], block[:, -1]),
                block[:, 2 * n : 2 * n + m],
                block[:, 2 * n + m : -1],
                block[:, -1],
            )
        near = self.walls.closest_many(x, y)
        rim, refl, clear = self.sense(x, y, h, near)
        if len(self._rest) < 1024:
            for i, key in enumerate(keys):
                self._rest[key] = np.concatenate(
                    (near[0][i], near[1][i], rim[i], refl[i], clear[i : i + 1])
                )
        return near, rim, refl, clear

    def sense(
        self, x: np.ndarray, y: np.ndarray, h: np.ndarray, near: Near | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise-free sonar rim distances, IR reflectances ``(k, n)`` and true clearances ``(k,)``
        at k poses (``near``: ``Walls.closest_many`` there, if already computed)."""
        rays, sectors, clear = self.walls.scan_many(
            x, y, h, self.offsets, self.n_sensors, self.cast_range, self.ir_reach, near
        )
        rim, refl = self.rim_refl(rays, sectors, clear)
        return rim, refl, clear

    def sense_one(
        self, x: float, y: float, h: float, near: tuple[np.ndarray, np.ndarray, float]
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """:meth:`sense` at one pose, on floats (``near``: ``Walls.closest`` there): rim distances
        and reflectances ``(1, n)`` and the clearance."""
        rays, sectors, clear = self.walls.scan(
            x, y, h, self.offsets, self.n_sensors, self.cast_range, self.ir_reach, near
        )
        # (the scalar scan gives sectors only within IR range: no row to blank)
        rim, refl = self.rim_refl(rays[None], None if sectors is None else sectors[None], None)
        return rim, refl, clear

    def rim_refl(
        self, rays: np.ndarray, sectors: np.ndarray | None, clear: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Sonar rim distances (the nearest sub-ray of a cone) and IR reflectances ``(k, n)``
        from the ray distances ``(k, R)``, sector distances ``(k, n)`` and clearances ``(k,)``
        (rows at or beyond IR range read 0; ``None``: no such row)."""
        robot = self.robot
        n = self.n_sensors
        if self.cone_rays > 1:
            rays = np.minimum.reduce(rays.reshape(len(rays), n, self.cone_rays), axis=2)
        rim = np.minimum(rays - robot.radius, robot.sonar_range)
        if sectors is None:  # nothing within IR range of any robot
            return rim, np.zeros((len(rays), n))
        r = robot.ir_range
        d = np.minimum(np.maximum(sectors - robot.radius, 0.0), r)
        refl = 100.0 * (1.0 - d * (1.0 / r)) ** 3
        if clear is not None:
            refl[clear >= self.ir_reach] = 0.0  # rows with nothing within IR range read 0
        return rim, refl

    def f1(self, sonar: np.ndarray, collision: np.ndarray) -> np.ndarray:
        """Eq. 3: -3 on a collision, -1 + d_min / d_c if the nearest sonar reading is below d_c."""
        close = self.robot.close_distance
        dmin = np.minimum.reduce(sonar, axis=1)
        f1 = np.where(dmin < close, -1.0 + dmin / close, 0.0)
        if collision.any():
            f1[collision] = -3.0
        return f1
