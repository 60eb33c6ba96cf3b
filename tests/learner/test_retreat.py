"""Backing out of a trap: the trail's test, the way back, and what the options give up."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.learner.retreat import Retreat

STEP, WINDOW = 0.2, 10


def retreat(batch: int = 1) -> Retreat:
    return Retreat(batch, 200, window=WINDOW, step=STEP)


def circle(centre: tuple[float, float], n: int, radius: float = 0.05) -> list[tuple[float, float]]:
    return [(centre[0] + radius * math.cos(k), centre[1] + radius * math.sin(k)) for k in range(n)]


def test_a_robot_on_its_way_never_backs_out() -> None:
    r = retreat()
    for k in range(100):
        assert r.observe(np.array([[STEP * k, 0.0]]), np.array([0])) == []
        assert not r.active[0]


def test_a_circling_robot_backs_out_to_where_it_was_a_window_before() -> None:
    r = retreat()
    path = [(STEP * k, 0.0) for k in range(12)] + circle((2.5, 0.5), 40)
    regions = [0] * 12 + [1] * 40
    started = None
    for t, (xy, region) in enumerate(zip(path, regions, strict=True)):
        r.observe(np.array([xy]), np.array([region]))
        if r.active[0]:
            started = t
            break
    # the last WINDOW actions got less than a tenth of WINDOW steps away: trapped then
    assert started is not None and started == 12 + WINDOW
    np.testing.assert_allclose(r.target[0], path[started - WINDOW])
    aim = np.array([[9.0, 9.0]])
    np.testing.assert_allclose(r.aim(aim)[0], r.target[0])


def test_a_retreat_ends_at_its_target_with_the_regions_visited_since() -> None:
    r = retreat()
    path = [(STEP * k, 0.0) for k in range(12)] + circle((2.5, 0.5), WINDOW + 1)
    regions = [0] * 11 + [1] + [2] * (WINDOW + 1)
    for xy, region in zip(path, regions, strict=True):
        r.observe(np.array([xy]), np.array([region]))
    assert r.active[0]
    target = r.target[0].copy()
    ended = r.observe(np.array([target + 0.1]), np.array([1]))
    assert [b for b, _ in ended] == [0] and not r.active[0]
    assert ended[0][1] == {1, 2}  # the pose backed out to lay in region 1
    aim = np.array([[9.0, 9.0]])
    np.testing.assert_array_equal(r.aim(aim), aim)
    # not trapped again before another window has passed
    for xy in circle(tuple(target), WINDOW - 1):
        assert r.observe(np.array([xy]), np.array([1])) == [] and not r.active[0]


def test_a_retreat_not_reached_in_time_ends() -> None:
    r = retreat()
    path = [(STEP * k, 0.0) for k in range(12)] + circle((2.5, 0.5), WINDOW + 1)
    for xy in path:
        r.observe(np.array([xy]), np.array([0]))
    assert r.active[0]
    steps = 0
    while not r.observe(np.array([[2.5, 0.5]]), np.array([0])):
        steps += 1
        assert steps < 100
    distance = math.dist((2.5, 0.5), r.target[0])
    assert steps >= math.floor(1.5 * distance / STEP) - 2


def test_a_robot_trapped_where_it_began_stays() -> None:
    r = retreat()
    for xy in circle((0.0, 0.0), 3 * WINDOW):
        assert r.observe(np.array([xy]), np.array([0])) == []
        assert not r.active[0]


def test_a_new_trial_forgets_the_trail() -> None:
    r = retreat()
    for xy in [(STEP * k, 0.0) for k in range(12)] + circle((2.5, 0.5), WINDOW + 1):
        r.observe(np.array([xy]), np.array([0]))
    assert r.active[0]
    r.begin_trial(np.array([0]))
    assert not r.active[0] and int(r.t[0]) == 0


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 3), st.floats(0.5, 3.0))
def test_rows_are_independent(row: int, speed: float) -> None:
    """Robot ``row`` circles while the others drive on at ``speed`` steps an action: only it
    backs out."""
    r = retreat(batch=4)
    for t in range(12 + WINDOW + 1):
        xy = np.array([[speed * STEP * t, float(b)] for b in range(4)])
        if t >= 12:
            xy[row] = circle((2.5, 0.5), t - 11)[-1]
        r.observe(xy, np.zeros(4, dtype=np.int64))
    assert r.active.tolist() == [b == row for b in range(4)]
