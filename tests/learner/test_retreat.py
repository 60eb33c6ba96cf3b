"""Backing out of a trap: the trail's test, the way back, and what it hands the options."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.learner.retreat import Retreat

STEP, WINDOW = 0.2, 31  # trapped: less than 0.62 m from where it was WINDOW actions before
A, B = (2.0, 0.5), (2.55, 0.5)  # to and fro across a region line at x = 2.3


def retreat(batch: int = 1) -> Retreat:
    return Retreat(batch, 200, window=WINDOW, step=STEP)


def to_and_fro(n: int) -> list[tuple[tuple[float, float], int]]:
    """A robot that drives 12 actions east, far from A, then goes to and fro between A (region
    0) and B (region 1) for ``n`` actions."""
    drive = [((STEP * k - 5.0, 0.5), 0) for k in range(12)]
    return drive + [((A, 0) if k % 2 == 0 else (B, 1)) for k in range(n)]


def feed(r: Retreat, steps: list[tuple[tuple[float, float], int]]) -> list:
    ended = []
    for xy, region in steps:
        ended += r.observe(np.array([xy]), np.array([region]))
    return ended


def test_a_robot_on_its_way_never_backs_out() -> None:
    r = retreat()
    for k in range(150):
        assert r.observe(np.array([[STEP * k, 0.0]]), np.array([0])) == []
        assert not r.active[0]


def test_a_trapped_robot_backs_out_to_where_it_was_a_window_before() -> None:
    r = retreat()
    steps = to_and_fro(40)
    t = 0
    for t, (xy, region) in enumerate(steps):  # noqa: B007 - t is read after the loop
        r.observe(np.array([xy]), np.array([region]))
        if r.active[0]:
            break
    # the first pose a window after the to and fro began, 0.55 m from that one
    assert t == 12 + WINDOW and steps[t][0] == B
    np.testing.assert_allclose(r.target[0], A)
    aim = np.array([[9.0, 9.0]])
    np.testing.assert_allclose(r.aim(aim)[0], A)


def test_a_retreat_ends_at_its_target_with_the_regions_visited_since() -> None:
    r = retreat()
    feed(r, to_and_fro(WINDOW + 1))
    assert r.active[0]
    ended = r.observe(np.array([[A[0] + 0.1, A[1]]]), np.array([0]))
    assert ended == [(0, {0, 1})] and not r.active[0]
    aim = np.array([[9.0, 9.0]])
    np.testing.assert_array_equal(r.aim(aim), aim)
    # not trapped again before another window has passed
    assert feed(r, to_and_fro(WINDOW - 1)[12:]) == [] and not r.active[0]


def test_a_retreat_not_reached_in_time_ends() -> None:
    r = retreat()
    feed(r, to_and_fro(WINDOW + 1))
    assert r.active[0]
    steps = 0
    while not r.observe(np.array([B]), np.array([1])):
        steps += 1
        assert steps < 100
    assert steps >= 4  # at least 5 actions to get there


def test_a_robot_trapped_where_it_was_a_window_before_stays() -> None:
    r = retreat()
    spin = [((2.0 + 0.05 * math.cos(k), 0.5 + 0.05 * math.sin(k)), 0) for k in range(90)]
    assert feed(r, spin) == [] and not r.active[0]


def test_a_new_trial_forgets_the_trail() -> None:
    r = retreat()
    feed(r, to_and_fro(WINDOW + 1))
    assert r.active[0]
    r.begin_trial(np.array([0]))
    assert not r.active[0] and int(r.t[0]) == 0
    assert feed(r, to_and_fro(WINDOW)) == [] and not r.active[0]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 3), st.floats(0.5, 3.0))
def test_rows_are_independent(row: int, speed: float) -> None:
    """Robot ``row`` goes to and fro while the others drive on at ``speed`` steps an action:
    only it backs out."""
    r = retreat(batch=4)
    steps = to_and_fro(WINDOW + 1)
    for t, (xy, region) in enumerate(steps):
        xys = np.array([[speed * STEP * t, float(b)] for b in range(4)])
        xys[row] = xy
        regions = np.zeros(4, dtype=np.int64)
        regions[row] = region
        r.observe(xys, regions)
    assert r.active.tolist() == [b == row for b in range(4)]


def test_after_backing_out_the_options_of_the_trap_are_given_up() -> None:
    """In the office's west office, a robot circling for two timeouts backs out, and the option
    it held there is given up for the trial (and another chosen)."""
    import torch

    from symrl.knowledge.rungs import Knowledge
    from symrl.learner.config import CrossingsConfig, OptionCriticConfig, OptionsConfig
    from symrl.learner.options import SubgoalOptions
    from symrl.world.robot import RobotConfig
    from symrl.world.worldmap import load_map

    told = Knowledge.told(load_map("office"), "regions")
    config = OptionsConfig(enabled=True, source="rules", region_limit=30, retreat=True)
    explore = OptionCriticConfig(epsilon=0.0, try_untried=False)
    opts = SubgoalOptions(
        told, 1, config, [0], None, explore, CrossingsConfig(enabled=True), RobotConfig(), 200
    )
    assert opts.retreat is not None and opts.retreat.window == 60
    opts.begin_trial(torch.tensor([0]))
    r = torch.tensor([opts.region_names.index("west_office")])
    # seven points round a circle of 0.3 m: 60 actions apart, 0.58 m apart
    spin = [
        (2.0 + 0.3 * math.cos(2 * math.pi * k / 7), 3.0 + 0.3 * math.sin(2 * math.pi * k / 7))
        for k in range(61)
    ]
    held = None
    for x, y in spin:
        held = int(opts.arrays["choice"][0, int(r[0])])
        opts.steer(r, torch.tensor([[x, y, 0.0]]), False)
    assert opts.retreat.active[0]
    target = opts.retreat.target[0].copy()
    _, option, entered, aim, _ = opts.steer(r, torch.tensor([[*target, 0.0]]), False)
    assert not opts.retreat.active[0]
    assert opts._trial_stalled[0, int(r[0]), held] and int(option[0]) != held
    assert bool(entered[0])  # the new choice is credited from here
