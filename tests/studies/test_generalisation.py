"""The generalisation study: poses, obstacle, tables, what the agent knows, the command."""

from __future__ import annotations

import json
import re

import numpy as np
import torch
from shapely.geometry import Point, Polygon

from symrl.assembly import build_policy
from symrl.cli import main
from symrl.knowledge.planner import shortest_path
from symrl.knowledge.route import option_table
from symrl.knowledge.rungs import Knowledge
from symrl.learner.config import load_config
from symrl.studies.generalisation import (
    NOISE_LEVELS,
    OBSTACLE,
    STARTS,
    _rate,
    markdown,
    transfer,
    world_start,
)
from symrl.studies.runner import evaluate_states, evaluation_batch
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
    evs = [
        {"reached_goal": True, "steps": 30, "collisions": 0},
        {"reached_goal": False, "steps": 200, "collisions": 4},
        {"reached_goal": True, "steps": 34, "collisions": 2},
    ]
    assert _rate(evs) == {
        "reached": 2,
        "runs": 3,
        "mean_steps_when_reached": 32.0,
        "mean_collisions": 2.0,
    }


def test_markdown_tables():
    r = {"reached": 1, "runs": 2, "mean_steps_when_reached": 40.0, "mean_collisions": 0.5}
    none = {"reached": 0, "runs": 2, "mean_steps_when_reached": None, "mean_collisions": 3.0}
    stat = {"mean": 30.0, "std": 1.0}
    report = {
        "recipe": "paper",
        "sets": 2,
        "trials": 20,
        "seeds": [100, 101],
        "provenance": {"revision": "abc1234", "dirty": True},
        "home_learned": r,
        "home_reflex_only": r,
        "obstacle_learned": none,
        "obstacle_reflex_only": r,
        "starts": [
            {
                "start": [1.0, -1.8, 0.0],
                "near_learned_route": True,
                "learned": none,
                "reflex_only": r,
            }
        ],
        "noise": [
            {
                "level": "sonar 0.05 m",
                "first_success": {"mean": 2.0, "std": 0.0, "never": 0},
                "success_last5": 0.9,
                "steps_last5": stat,
                "total_reinforcement_last5": stat,
                "collisions_all_trials": stat,
            }
        ],
    }
    md = markdown(report)
    assert "seeds 100-101, code `abc1234+dirty`" in md
    assert "| (1, -1.8, 0 deg) | yes | 0/2 | 1/2 (40.0) |" in md
    assert "| learned controller | 0/2 | 3.0 |" in md
    assert "| sonar 0.05 m | 2.0 (0) | 90% |" in md


def test_the_new_obstacle_is_in_the_env_and_not_in_what_the_agent_knows():
    """The agent's option table, route planner and localiser walls are the training map's;
    the robots drive in the map with the box, so their path cannot cross it."""
    config = load_config("paper_map", [])  # told the map: its table, planner and walls
    world = load_map("hailu2001")
    blocked = world.with_obstacle(OBSTACLE)
    state = build_policy(config, world, [0]).robot_state(0)
    home = world_start(world)
    policy, env = evaluation_batch(config, world, [state], [home], [5], env_world=blocked)
    try:
        assert env.world is blocked
        assert policy.knowledge.world is world
        trained = option_table(Knowledge.told(world, "map"), "map")
        assert policy.options.route is not None and policy.options.route.world is world
        # told of the box, the planner would route round it
        assert len(shortest_path(world).points) != len(shortest_path(blocked).points)
        assert policy.options.table.labels == trained.labels
        torch.testing.assert_close(policy.options.table.points, trained.points)
        np.testing.assert_array_equal(
            policy.perception.tracker.localizer.walls.segments, Walls(world.segments).segments
        )
        assert len(blocked.segments) == len(world.segments) + 4
    finally:
        env.close()
    (free,) = evaluate_states(config, world, [state], [home], [5])
    (boxed,) = evaluate_states(config, world, [state], [home], [5], env_world=blocked)
    box = Polygon(OBSTACLE)
    assert any(box.distance(Point(p)) < 0.3 for p in free["path"])  # its way runs by the box
    assert all(box.distance(Point(p)) > 0.25 for p in boxed["path"])  # the body stays outside
    assert boxed["path"] != free["path"]


def test_generalise_runs_from_its_defaults(tmp_path, capsys):
    """The command's own noise levels and recipes, at a tiny budget, end to end."""
    assert all(key.startswith("env.robot.") for _, keys in NOISE_LEVELS for key in keys)
    out = tmp_path / "gen"
    assert (
        main(["generalise", "--sets", "1", "--trials", "1", "--workers", "1", "--out", str(out)])
        == 0
    )
    report = json.loads((out / "generalise.json").read_text())
    assert report["recipe"] == "paper" and report["map"] == "hailu2001"
    assert [n["level"] for n in report["noise"]] == [label for label, _ in NOISE_LEVELS]
    assert len(report["starts"]) == len(STARTS)
    assert report["obstacle_learned"]["runs"] == report["obstacle_reflex_only"]["runs"] == 1
    for name in ("generalise.md", "starts.png", "obstacle.png"):
        assert (out / name).is_file(), name
    assert "| learned controller |" in capsys.readouterr().out


def test_the_reflex_alone_can_be_the_recipe_under_test():
    """``--recipe reflex_only``: the learned column is the recipe's, the other the reflex's."""
    (row,) = transfer("reflex_only", sets=1, trials=1, seed=3)
    assert set(row) == {"set", "seed", "learned", "reflex_only"}
    assert row["learned"]["home"] == row["reflex_only"]["home"]  # nothing to learn in one trial


def test_greedy_trials_count_their_steps_on_a_bar_and_drive_the_same_without_it(capsys):
    """On a big world the greedy trials after training take minutes: with a label they show a
    bar of the batch's steps on stderr, and the records are those driven without one."""
    config = load_config("paper", [])
    world = load_map("hailu2001")
    state = build_policy(config, world, [0]).robot_state(0)
    starts = [world_start(world), (1.0, -1.8, 0.0)]
    quiet = evaluate_states(config, world, [state, state], starts, [5, 6])
    assert capsys.readouterr().err == ""
    shown = evaluate_states(config, world, [state, state], starts, [5, 6], progress="greedy")
    err = capsys.readouterr().err
    assert shown == quiet
    counts = [int(n) for n in re.findall(r"greedy: (\d+)step", err)]  # refreshed ~10 per s
    assert counts and max(counts) <= max(r["steps"] for r in quiet)
