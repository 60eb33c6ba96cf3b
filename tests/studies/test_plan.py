"""`symrl plan`'s walk: the moves it counts and their check against the env's geometry."""

from __future__ import annotations

import numpy as np
import pytest

from symrl.knowledge.planner import shortest_path
from symrl.studies.plan import check_walk, chord_walk
from symrl.world import load_map


def test_chord_walk_counts_the_moves_of_a_straight_line():
    poses = chord_walk(np.array([[0.0, 0.0], [1.0, 0.0]]), 0.2, (1.0, 0.0), 0.1)
    assert len(poses) - 1 == 5  # 0.9 m to the rim in 0.2 m moves
    np.testing.assert_allclose(np.diff(poses[:, 0]), 0.2, atol=1e-12)


def test_paper_world_optimum_is_25_actions_and_the_walk_is_legal():
    world = load_map("hailu2001")
    plan = shortest_path(world)
    assert plan.length == pytest.approx(4.913, abs=2e-3)
    assert plan.actions == 25
    outer = shortest_path(world, clearance=plan.clearance + 0.002)
    walk = chord_walk(outer.points, 0.2, (world.goal.x, world.goal.y), world.goal.radius)
    check = check_walk(world, walk, 0.26, plan.clearance)
    assert check == {**check, "moves": 25, "sweep_contacts": 0, "virtual_collisions": 0}
