"""The B21 robot model (paper sections 3.1 and 4): body, action, sensors, noise.

Every number that shapes the simulated robot lives in :class:`RobotConfig`, with the paper's
value (or a documented choice where the paper is silent, docs/explanation/algorithm.md) as its
default.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["RobotConfig", "odometry_drift"]


@dataclass(frozen=True)
class RobotConfig:
    """The simulated B21: a disc that rotates then translates, with sonar, IR, bumper, odometry."""

    radius: float = 0.26
    """Body radius in metres (the B21 enclosure)."""
    step: float = 0.20
    """Translation l after every rotation, metres."""
    n_sensors: int = 24
    """Sonars and IR sensors each, evenly spaced: sensor k at heading + k*360/n_sensors deg."""
    sonar_range: float = 5.0
    """Sonar readings (rim distance) are capped here; the observation divides by it."""
    sonar_noise_std: float = 0.01
    """Std of the Gaussian noise added to every sonar reading, metres (0 with noise=False)."""
    sonar_cone_deg: float = 0.0
    """Full aperture of a sonar beam in degrees; 0 is a thin ray (default). When > 0 a reading is
    the minimum over ``sonar_cone_rays`` sub-rays spread evenly across the cone."""
    sonar_cone_rays: int = 5
    """Sub-rays per sonar when ``sonar_cone_deg > 0`` (ignored otherwise)."""
    ir_range: float = 0.5
    """IR sensors see walls within this rim distance; reflectance = 100*(1 - d/ir_range)^3."""
    ir_collision_threshold: float = 70.0
    """A reflectance above this is a virtual collision (paper section 5: 70, i.e. d < 0.056 m)."""
    close_distance: float = 0.30
    """d_c of Eq. 3: a sonar rim distance below it gives f1 = -1 + min_j d_j / d_c."""
    translation_noise: float = 0.01
    """Std of the true translation as a fraction of l (1% of 0.20 m); 0 with noise=False."""
    rotation_noise_deg: float = 0.5
    """Std of the true rotation in degrees; 0 with noise=False."""
    perfect_odometry: bool = False
    """If True the odometry pose is the true pose (motion noise still moves the robot)."""

    def __post_init__(self) -> None:
        positive = ("radius", "step", "sonar_range", "ir_range", "close_distance")
        non_negative = (
            "sonar_noise_std",
            "sonar_cone_deg",
            "translation_noise",
            "rotation_noise_deg",
        )
        for name in positive + non_negative + ("ir_collision_threshold",):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"RobotConfig.{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"RobotConfig.{name} must be finite, got {value!r}")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(
                    f"RobotConfig.{name} must be positive, got {getattr(self, name)!r}"
                )
        for name in non_negative:
            if getattr(self, name) < 0:
                raise ValueError(
                    f"RobotConfig.{name} must be non-negative, got {getattr(self, name)!r}"
                )
        # upper bounds: every step casts n_sensors * sonar_cone_rays rays per robot
        for name, low, high in (("n_sensors", 3, 360), ("sonar_cone_rays", 1, 100)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
                raise ValueError(
                    f"RobotConfig.{name} must be an integer >= {low} and <= {high}, got {value!r}"
                )
        if self.sonar_cone_deg >= 360.0:
            raise ValueError(
                f"RobotConfig.sonar_cone_deg must be below 360, got {self.sonar_cone_deg!r}"
            )
        if not 0.0 < self.ir_collision_threshold < 100.0:
            raise ValueError(
                "RobotConfig.ir_collision_threshold must be in (0, 100), "
                f"got {self.ir_collision_threshold!r}"
            )
        if not isinstance(self.perfect_odometry, bool):
            raise ValueError(
                f"RobotConfig.perfect_odometry must be true or false, got {self.perfect_odometry!r}"
            )

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> RobotConfig:
        """Build from a mapping; an unknown key raises ValueError naming it."""
        if not isinstance(values, dict):
            raise ValueError(f"robot config must be a mapping of fields, got {values!r}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ValueError(f"RobotConfig: unknown field(s) {unknown}; allowed: {sorted(known)}")
        return cls(**values)

    @classmethod
    def coerce(cls, robot: RobotConfig | dict[str, Any] | None) -> RobotConfig:
        """A RobotConfig from None (the defaults), a dict of its fields, or itself."""
        if robot is None:
            return cls()
        if isinstance(robot, dict):
            return cls.from_dict(robot)
        if not isinstance(robot, RobotConfig):
            raise ValueError(f"robot must be a RobotConfig or a dict of its fields, got {robot!r}")
        return robot

    @property
    def ir_collision_distance(self) -> float:
        """Rim distance below which the reflectance exceeds the threshold (0.056 m by default)."""
        return self.ir_range * (1.0 - (self.ir_collision_threshold / 100.0) ** (1.0 / 3.0))

    def reflectance(self, rim_distance: Any) -> Any:
        """IR reflectance 100*(1 - d/ir_range)^3 for d < ir_range, else 0 (numpy or float)."""
        d = np.clip(np.asarray(rim_distance, dtype=np.float64), 0.0, self.ir_range)
        return 100.0 * (1.0 - d / self.ir_range) ** 3


def odometry_drift(
    n: np.ndarray, step: float, translation_noise: float, rotation_noise: float
) -> np.ndarray:
    """One standard deviation (m) of the odometry's position error after ``n`` actions of
    ``step`` metres: the translation noise (a fraction of the step) and the heading's random
    walk (``rotation_noise`` radians an action) integrated along the path. The robot's own
    model of how far its belief can have drifted (the crossing map and the goal scans use it)."""
    return step * np.sqrt(translation_noise**2 * n + rotation_noise**2 * n**3 / 3)
