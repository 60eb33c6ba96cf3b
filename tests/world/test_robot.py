"""RobotConfig: the paper's defaults and clear errors naming the field and the value."""

import dataclasses
import inspect

import numpy as np
import pytest

from symrl.world.robot import RobotConfig


def test_defaults_are_the_papers():
    cfg = RobotConfig()
    assert (cfg.radius, cfg.step, cfg.n_sensors) == (0.26, 0.20, 24)
    assert (cfg.sonar_range, cfg.sonar_noise_std, cfg.sonar_cone_deg) == (5.0, 0.01, 0.0)
    assert (cfg.ir_range, cfg.ir_collision_threshold, cfg.close_distance) == (0.5, 70.0, 0.30)
    assert (cfg.translation_noise, cfg.rotation_noise_deg, cfg.perfect_odometry) == (
        0.01,
        0.5,
        False,
    )


def test_every_field_is_documented():
    lines = inspect.getsource(RobotConfig).splitlines()
    for f in dataclasses.fields(RobotConfig):
        i = next(i for i, s in enumerate(lines) if s.strip().startswith(f"{f.name}:"))
        assert lines[i + 1].strip().startswith('"""'), f.name


def test_reflectance_curve():
    cfg = RobotConfig()
    np.testing.assert_allclose(cfg.reflectance([0.0, 0.1, 0.25, 0.5, 0.8]), [100, 51.2, 12.5, 0, 0])


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("radius", -0.26, "positive"),
        ("radius", 0.0, "positive"),
        ("step", "far", "number"),
        ("sonar_range", float("nan"), "finite"),
        ("sonar_noise_std", -0.01, "non-negative"),
        ("rotation_noise_deg", -1.0, "non-negative"),
        ("n_sensors", 2, "integer >= 3"),
        ("n_sensors", 24.0, "integer >= 3"),
        ("sonar_cone_rays", 0, "integer >= 1"),
        ("sonar_cone_deg", 400.0, "below 360"),
        ("ir_collision_threshold", 120.0, r"\(0, 100\)"),
        ("perfect_odometry", "yes", "true or false"),
        ("close_distance", True, "number"),
    ],
)
def test_bad_field_names_field_and_value(field, value, message):
    with pytest.raises(ValueError, match=rf"RobotConfig\.{field} .*{message}") as err:
        RobotConfig(**{field: value})
    assert repr(value) in str(err.value) or field in ("ir_collision_threshold",)


def test_from_dict_rejects_unknown_keys():
    assert RobotConfig.from_dict({"radius": 0.3}).radius == 0.3
    with pytest.raises(ValueError, match="radiu"):
        RobotConfig.from_dict({"radiu": 0.3})
    with pytest.raises(ValueError, match="mapping"):
        RobotConfig.from_dict([("radius", 0.3)])
