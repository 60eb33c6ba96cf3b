"""A trial's step budget follows the world's size; every shipped world keeps the paper's 200."""

from __future__ import annotations

import pytest

from symrl.learner.config import load_config
from symrl.train import make_env
from symrl.world import load_map
from symrl.world.budget import step_budget
from symrl.world.worldmap import SUITES, builtin_maps, suite_maps


def floor(width: float, height: float) -> dict:
    return {
        "boundary": [[0, 0], [width, 0], [width, height], [0, height]],
        "start": {"x": 1.0, "y": 1.0},
        "goal": {"x": width - 1, "y": height - 1, "radius": 0.4},
        "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
    }


@pytest.mark.parametrize("name", builtin_maps() + [n for s in SUITES for n in suite_maps(s)])
def test_every_shipped_world_keeps_200(name):
    assert step_budget(load_map(name), 200, 0.2) == 200


def test_a_building_gets_a_budget_in_proportion():
    assert step_budget(load_map(floor(30.0, 50.0)), 200, 0.2) == 800  # 160 m over 40 m
    assert step_budget(load_map(floor(30.0, 50.0)), 3, 0.2) == 12
    assert step_budget(load_map("hailu2001"), 3, 0.2) == 3  # a short budget stays short


def test_training_envs_take_the_budget():
    config = load_config("paper_map", [])
    assert make_env(config, [0], world=load_map(floor(30.0, 50.0))).physics.max_actions == 800
    assert make_env(config, [0]).physics.max_actions == 200
