"""`symrl plan --reward`: the best total reinforcement found by search, against totals worked
out by hand and against the shortest path's."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import yaml

from symrl.cli import main
from symrl.knowledge.planner import shortest_path
from symrl.studies.plan import chord_walk
from symrl.studies.reward_optimum import (
    SearchSettings,
    headings_to_actions,
    replay,
    rollout,
    search_best_total,
    walk_headings,
)
from symrl.world import load_map
from symrl.world.robot import RobotConfig

SMALL = SearchSettings(
    beam=20,
    headings=36,
    dp_spacing=0.2,
    dp_headings=24,
    refine_start_deg=1.0,
    refine_stop_deg=0.5,
    random=8,
)

# a corridor 1.1 m wide: on its centre line the sonars at +-90 degrees read 0.55 - 0.26 =
# 0.29 m, below d_c = 0.30 m, so every action there pays f1 = -1 + 0.29 / 0.30
CORRIDOR = {
    "name": "corridor",
    "boundary": [[0.0, 0.0], [6.0, 0.0], [6.0, 1.1], [0.0, 1.1]],
    "start": {"x": 0.8, "y": 0.55, "heading": 1.0},
    "goal": {"x": 3.95, "y": 0.55, "radius": 0.4},
    "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
}


def test_in_a_corridor_the_best_is_straight_down_the_middle_at_the_hand_computed_total():
    world = load_map(CORRIDOR)
    best = search_best_total(world, settings=replace(SMALL, endings=2))
    assert [stage for stage, _ in best.history[2:]] == [
        "beam 1, ending 1",
        "refined",
        "beam 1, ending 2",
        "refined",
    ]
    # 3.15 m to the goal's centre, 2.75 m to its rim: 14 moves of 0.20 m, each paying only f1
    assert len(best.actions) == 14
    assert best.total == pytest.approx(14 * (-1.0 + 0.29 / 0.30), abs=1e-9)
    np.testing.assert_allclose(best.headings, 0.0, atol=1e-9)
    assert best.actions[0] == pytest.approx(-1.0)  # the first action turns from the start


def test_in_an_open_room_the_best_is_straight_at_the_goal_and_pays_nothing():
    room = {
        **CORRIDOR,
        "boundary": [[-3.0, -3.0], [8.0, -3.0], [8.0, 4.0], [-3.0, 4.0]],
        "start": {"x": 0.0, "y": 0.0, "heading": 0.0},
        "goal": {"x": 3.0, "y": 1.0, "radius": 0.4},
    }
    best = search_best_total(load_map(room), settings=SMALL)
    assert best.total == pytest.approx(0.0, abs=1e-12)  # atan2's last bit
    np.testing.assert_allclose(best.headings, np.arctan2(1.0, 3.0), atol=1e-12)
    assert len(best.actions) == int(np.ceil((np.hypot(3.0, 1.0) - 0.4) / 0.2))


def test_on_the_paper_world_the_search_beats_the_shortest_path_and_replays_exactly():
    world = load_map("hailu2001")
    start = (world.start.x, world.start.y, world.start.heading)
    plan = shortest_path(world, start)
    outer = shortest_path(world, start, clearance=plan.clearance + 0.002)
    walk = chord_walk(outer.points, 0.2, (world.goal.x, world.goal.y), world.goal.radius)
    seed = walk_headings(walk)
    short = rollout(world, RobotConfig(), start, seed[None])
    assert short.steps[0] == 25 and short.collisions[0] == 0
    best = search_best_total(world, start, [seed], SMALL)
    assert best.total > short.total[0] + 3.0  # the shortest path runs along the walls
    again = replay(world, RobotConfig(), start, best.actions.tolist())
    assert again["reached_goal"] and again["collisions"] == 0
    assert again["total"] == pytest.approx(best.total, abs=1e-9)
    assert again["total"] == pytest.approx(sum(again["f1"]) + sum(again["f2"]), abs=1e-12)
    wider = search_best_total(world, start, [seed], replace(SMALL, grids=2))
    assert wider.total >= best.total  # its first beam is the same, another is refined
    assert len(wider.history) == len(best.history) + 2


def test_a_sequence_that_misses_the_goal_scores_minus_infinity():
    world = load_map(CORRIDOR)
    totals = rollout(world, RobotConfig(), (0.8, 0.55, 0.0), np.zeros((2, 14)) + [[0.0], [0.3]])
    assert totals.total[0] == pytest.approx(14 * (-1.0 + 0.29 / 0.30), abs=1e-9)
    assert totals.total[1] == -np.inf  # drives into the wall


def test_actions_are_the_turns_between_headings():
    turns = headings_to_actions(np.array([3.0, -3.0, -2.0]), 0.0)
    np.testing.assert_allclose(turns, [3.0, -6.0 + 2 * np.pi, 1.0], atol=1e-12)


def test_plan_reward_writes_the_result_and_the_figure(tmp_path, capsys):
    path = tmp_path / "corridor.yaml"
    path.write_text(yaml.safe_dump(CORRIDOR))
    out = tmp_path / "plan"
    argv = [
        "plan",
        "--map",
        str(path),
        "--reward",
        "--beam",
        "10",
        "--headings",
        "24",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    result = json.loads((out / "reward_optimum.json").read_text())
    assert result["actions"] == 14 and result["collisions"] == 0
    assert result["total_reinforcement"] == pytest.approx(14 * (-1 + 0.29 / 0.30), abs=1e-9)
    assert result["f2_heading"] == pytest.approx(0.0, abs=1e-12)
    assert result["total_reinforcement"] >= result["shortest_path"]["total_reinforcement"]
    blind = result["noise_on_open_loop"]  # the odometry turns as told: f2 stays 0
    assert blind["reached_goal"] > 50 and blind["f2_when_reached"] == pytest.approx(0, abs=1e-9)
    assert (out / "reward_optimum.png").stat().st_size > 0
    assert "best total reinforcement found" in capsys.readouterr().out
    assert main(argv) != 0  # the results are there: --overwrite replaces them
    assert "reward_optimum.json" in capsys.readouterr().err


@pytest.mark.parametrize("flag, value", [("--beam", "0"), ("--headings", "2")])
def test_bad_search_settings_are_one_line(flag, value, tmp_path, capsys):
    assert main(["plan", "--reward", flag, value, "--out", str(tmp_path / "p")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{flag} {value}" in err
