"""Table 1, the ablation summary and the PPO reliability rule on hand-made trial tables."""

from __future__ import annotations

import math

import pytest

from symrl.runs import read_trials_csv, write_trials_csv
from symrl.studies.ablation import summarise, summary_markdown
from symrl.studies.repeatability import table1_markdown
from symrl.studies.runner import table1


def _row(s, t, steps, total, neurons, reached=True, collisions=0):
    return {
        "set": s,
        "seed": 100 + s,
        "trial": t,
        "steps": steps,
        "total_reinforcement": total,
        "neurons": neurons,
        "collisions": collisions,
        "reached_goal": reached,
    }


def test_table1_is_mean_and_sample_variance_at_the_last_trial():
    rows = [_row(s, 1, 40, -20.0, 10) for s in range(3)]  # first trials must be ignored
    rows += [_row(0, 2, 27, -6.0, 80), _row(1, 2, 28, -7.0, 82), _row(2, 2, 29, -5.0, 84)]
    t = table1(rows)
    assert (t["sets"], t["trial"]) == (3, 2)
    assert t["neurons"] == {"mean": 82.0, "variance": 4.0, "min": 80.0, "max": 84.0}
    assert t["steps"]["mean"] == 28.0 and t["steps"]["variance"] == 1.0
    assert t["total_reinforcement"]["mean"] == -6.0 and t["total_reinforcement"]["variance"] == 1.0
    md = table1_markdown("x", t, {"steps": 25, "length_m": 4.913})
    assert "| steps | 28.00 | 1.000 |" in md and "27.7" in md and "25 (4.913 m)" in md


def test_table1_rejects_an_empty_table():
    with pytest.raises(ValueError, match="no trial rows"):
        table1([])


def test_summary_on_a_hand_made_table():
    steps0 = [200, 200, 30, 30, 28, 28]
    rows = [
        _row(0, t + 1, s, -s / 3, 10 * (t + 1), reached=t >= 2, collisions=1)
        for t, s in enumerate(steps0)
    ]
    rows += [_row(1, t + 1, 200, -90.0, 50, reached=False, collisions=2) for t in range(6)]
    s = summarise(rows)
    assert s["first_success"] == {"mean": 3.0, "std": 0.0, "ci95": [3.0, 3.0], "never": 1}
    assert s["success_last5"] == pytest.approx(0.4)  # 4 of set 0's last 5, none of set 1's
    assert s["steps_last5"]["mean"] == pytest.approx((63.2 + 200) / 2)
    assert s["steps_last5"]["std"] == pytest.approx((200 - 63.2) / math.sqrt(2))
    assert s["neurons_last"]["mean"] == 55.0
    coll = s["collisions_all_trials"]
    assert coll["mean"] == 9.0 and coll["std"] == pytest.approx(3 * math.sqrt(2))
    # the bootstrap interval of the mean of (6, 12) lies within the two sets' values
    assert 6.0 <= coll["ci95"][0] <= 9.0 <= coll["ci95"][1] <= 12.0
    md = summary_markdown({"demo": s})
    assert "| demo | 2 × 6 | 3.0 ± 0.0 (1) | 40% |" in md


def test_trials_csv_round_trip(tmp_path):
    rows = [_row(0, 1, 30, -9.5, 12), _row(0, 2, 28, -8.0, 14, reached=False)]
    write_trials_csv(tmp_path / "t.csv", rows)
    back = read_trials_csv(tmp_path / "t.csv")
    assert back[1]["reached_goal"] is False and back[0]["total_reinforcement"] == -9.5
    assert table1(back)["steps"]["mean"] == 28.0
