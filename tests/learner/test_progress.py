"""TrialProgress: what the update counts across trials besides the experts and the options."""

from __future__ import annotations

import math

import numpy as np
import pytest

from symrl.learner.progress import TrialProgress


def test_a_better_success_raises_the_bar_a_failure_or_a_worse_one_does_not():
    p = TrialProgress(3, 0.1)
    rows = np.array([0, 2])
    improved = p.improve(rows, np.array([-10.0, -4.0]), np.array([True, False]))
    assert improved.tolist() == [True, False]
    assert p.best_total.tolist() == [-10.0, -math.inf, -math.inf]
    improved = p.improve(np.array([0]), np.array([-12.0]), np.array([True]))  # worse
    assert improved.tolist() == [False] and float(p.best_total[0]) == -10.0


def test_cooling_to_the_floor_and_counting_touch_only_the_rows_given():
    p = TrialProgress(2, 0.1)
    for _ in range(3):
        p.cool(np.array([1]), 0.5, 0.02)
        p.count(np.array([1]))
    assert p.temperature.tolist() == pytest.approx([0.1, 0.02])  # 0.1 / 8 < 0.02
    assert p.trials_done.tolist() == [0, 3]


def test_its_state_loads_into_a_fresh_one():
    p = TrialProgress(2, 0.1)
    p.cool(np.array([0]), 0.5, 0.0)
    p.improve(np.array([1]), np.array([-3.0]), np.array([True]))
    fresh = TrialProgress(2, 0.1)
    fresh.load_state_dict(p.state_dict())
    fresh.cool(np.array([0]), 0.5, 0.0)  # the views follow the loaded buffers
    assert fresh.temperature.tolist() == pytest.approx([0.025, 0.1])
    assert fresh.best_total.tolist() == [-math.inf, -3.0]
