"""The goal search: a robot that stands on the goal by its odometry, while the true goal lies
elsewhere, spirals outward until it crosses the true goal disc."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.search import GoalSearch

GOAL, RADIUS, STEP = (0.0, 0.0), 0.4, 0.2
_MAX_TURN = math.pi / 4  # the reflex's output sets in `paper` peak at 45 degrees


def _drive(search: GoalSearch | None, pose: np.ndarray, true_goal: np.ndarray, steps: int) -> int:
    """An ideal reflex (turn toward the target, at most 45 degrees, then 0.2 m) whose odometry
    is right about its motion but wrong about where the goal is; the step it reaches the true
    goal disc, or -1."""
    pose = pose.astype(np.float64).copy()
    for k in range(steps):
        bearing = math.atan2(GOAL[1] - pose[1], GOAL[0] - pose[0]) - pose[2]
        target = np.array([(bearing + math.pi) % (2 * math.pi) - math.pi])
        if search is not None:
            target, _ = search.steer(pose[None], target, np.array([GOAL]))
        pose[2] += float(np.clip(target[0], -_MAX_TURN, _MAX_TURN))
        pose[:2] += STEP * np.array([math.cos(pose[2]), math.sin(pose[2])])
        if math.dist(pose[:2], true_goal) <= RADIUS:
            return k
    return -1


def test_no_search_before_the_robot_is_deep_inside_the_goal_disc():
    search = GoalSearch(GOAL, RADIUS, 2)
    pose = np.array([[1.0, 0.0, math.pi], [0.25, 0.0, math.pi]])  # 0.25 m: inside, not deep
    target, aim = np.array([0.1, -0.2]), np.array([[0.0, 0.0], [0.0, 0.0]])
    t, a = search.steer(pose, target, aim)
    assert np.array_equal(t, target) and np.array_equal(a, aim)
    assert not search.searching.any()


def test_the_spiral_starts_ahead_in_the_robots_own_sense_and_mirrors():
    search = GoalSearch(GOAL, RADIUS, 2)
    # at (0.1, 0) heading up (counter-clockwise about the goal), and its mirror image
    pose = np.array([[0.1, 0.0, math.pi / 2], [0.1, 0.0, -math.pi / 2]])
    t, a = search.steer(pose, np.zeros(2), np.zeros((2, 2)))
    assert search.searching.all()
    assert a[0, 1] > 0 > a[1, 1]  # ahead: up for the first, down for the mirror
    np.testing.assert_allclose(a[1], a[0] * [1, -1], atol=1e-12)
    np.testing.assert_allclose(t[1], -t[0], atol=1e-12)
    assert math.hypot(*a[0]) > 0.75 * RADIUS  # on the spiral, past its start radius
    search.begin_trial(np.array([0]))
    assert search.searching.tolist() == [False, True]


def test_the_spiral_widens_by_its_spacing_per_turn():
    search = GoalSearch(GOAL, RADIUS, 1, spacing=0.5)
    pose = np.array([[0.1, 0.0, math.pi / 2]])
    search.steer(pose, np.zeros(1), np.zeros((1, 2)))
    rho0 = float(search.rho[0])
    steps = 0
    while float(search.rho[0]) < rho0 + 0.5:  # one turn's length: 2 pi rho, 0.2 m a step
        search.steer(pose, np.zeros(1), np.zeros((1, 2)))
        steps += 1
    assert 2 * math.pi * rho0 / STEP < steps < 2 * math.pi * (rho0 + 0.5) / STEP


@settings(max_examples=40, deadline=None)
@given(
    drift=st.floats(0.25, 1.2),
    direction=st.floats(-math.pi, math.pi),
    heading=st.floats(-math.pi, math.pi),
)
def test_a_drifted_robot_finds_the_true_goal(drift, direction, heading):
    true_goal = drift * np.array([math.cos(direction), math.sin(direction)])
    start = np.array([0.0, 0.0, heading])
    if math.dist(start[:2], true_goal) <= RADIUS:
        return  # already there
    assert _drive(GoalSearch(GOAL, RADIUS, 1), start, true_goal, 150) >= 0


def test_without_the_search_the_robot_circles_its_odometry_goal():
    true_goal = np.array([1.0, 0.0])  # farther than its circle about the odometry goal reaches
    assert _drive(None, np.array([0.0, 0.0, math.pi / 2]), true_goal, 150) == -1
    assert _drive(GoalSearch(GOAL, RADIUS, 1), np.array([0.0, 0.0, math.pi / 2]),
                  true_goal, 150) >= 0
