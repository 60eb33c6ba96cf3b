"""The generalisation study's pieces that need no training: poses, obstacle, tables."""

from __future__ import annotations

import numpy as np

from symrl.studies.generalisation import OBSTACLE, STARTS, _rate, markdown
from symrl.world import load_map
from symrl.world.geometry import Walls


def test_start_poses_are_free_and_the_obstacle_blocks_the_straight_route():
    world = load_map("hailu2001").with_obstacle(OBSTACLE)
    walls = Walls(world.segments)
    for x, y, _ in STARTS:
        assert world.in_free_area(x, y) and walls.clearance(np.array([[x, y]]))[0] > 0.316
    # the straight line from the start to the door's middle runs through the box
    assert not world.in_free_area(2.0, -0.5 * 2.0 / 3.6)


def test_rate_counts_successes_and_averages_steps_of_successes_only():
    evs = [{"reached_goal": True, "steps": 30, "collisions": 0},
           {"reached_goal": False, "steps": 200, "collisions": 4},
           {"reached_goal": True, "steps": 34, "collisions": 2}]
    assert _rate(evs) == {"reached": 2, "runs": 3, "mean_steps_when_reached": 32.0,
                          "mean_collisions": 2.0}


def test_markdown_tables():
    r = {"reached": 1, "runs": 2, "mean_steps_when_reached": 40.0, "mean_collisions": 0.5}
    none = {"reached": 0, "runs": 2, "mean_steps_when_reached": None, "mean_collisions": 3.0}
    stat = {"mean": 30.0, "std": 1.0}
    report = {
        "recipe": "paper_map", "sets": 2, "trials": 20, "seeds": [100, 101],
        "home_learned": r, "home_reflex_only": r, "obstacle_learned": none,
        "obstacle_reflex_only": r,
        "starts": [{"start": [1.0, -1.8, 0.0], "near_learned_route": True, "learned": none,
                    "reflex_only": r}],
        "noise": [{"level": "sonar 0.05 m", "first_success": {"mean": 2.0, "std": 0.0, "never": 0},
                   "success_last5": 0.9, "steps_last5": stat, "total_reinforcement_last5": stat,
                   "collisions_all_trials": stat}],
    }
    md = markdown(report)
    assert "| (1, -1.8, 0 deg) | yes | 0/2 | 1/2 (40.0) |" in md
    assert "| learned controller | 0/2 | 3.0 |" in md
    assert "| sonar 0.05 m | 2.0 (0) | 90% |" in md
