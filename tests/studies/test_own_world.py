"""Every command on a map other than the paper's: its files, its figures, its optimum; start
poses and the new obstacle taken from the map."""

from __future__ import annotations

import json
import math

import pytest
import shapely
from shapely.geometry import MultiLineString, Point, Polygon

from symrl.cli import main
from symrl.studies.generalisation import (
    OBSTACLE,
    STARTS,
    obstacle_for,
    run_generalisation,
    starts_for,
)
from symrl.studies.placement import derived_obstacle, derived_starts, map_starts, study_starts
from symrl.studies.repeatability import OTHER_STARTS, run_study
from symrl.studies.runner import optimum
from symrl.world import load_map
from symrl.world.worldmap import BODY_RADIUS, MapError, reaches_goal

GALLERY = (
    "two_doors",
    "two_door_room",
    "office",
    "l_corridor",
    "maze",
    "dead_end",
    "hailu2001_mirror",
)
FIGURES = "l_corridor"  # the one map whose study also draws its figures (the rest: tables only)
SHORT = "env.max_actions=60"  # trials cut at 60 actions: the reflex is stuck for 200 on some maps


@pytest.mark.parametrize("name", GALLERY)
def test_drive_train_and_study_run_on_the_map(name, tmp_path):
    assert main(["drive", "--map", name, "--no-noise", "--out", str(tmp_path / "drive")]) == 0
    assert (tmp_path / "drive").is_dir() and any((tmp_path / "drive").glob("*.png"))
    assert (
        main(
            [
                "train",
                "paper_map",
                "--trials",
                "2",
                "--map",
                name,
                "--logdir",
                str(tmp_path / "train"),
                SHORT,
            ]
        )
        == 0
    )
    assert (tmp_path / "train" / "trials.csv").is_file()
    out = tmp_path / "study"
    if name == FIGURES:
        assert (
            main(
                [
                    "study",
                    "paper_map",
                    "--sets",
                    "2",
                    "--trials",
                    "2",
                    "--map",
                    name,
                    "--out",
                    str(out),
                    SHORT,
                ]
            )
            == 0
        )
        for png in ("curves.png", "trajectories.png", "ghosts.png"):
            assert (out / png).stat().st_size > 0, png
    else:
        study = run_study(
            "paper_map",
            sets=2,
            trials=2,
            overrides=[f"env.map={name}", SHORT],
            out=out,
            figures=False,
            progress=False,
        )
        assert study.world.name == name
    table = json.loads((out / "table1.json").read_text())
    assert table["optimum"]["steps"] == optimum(name)["steps"]
    assert "paper_map" not in table and table["map"] == name  # the paper's numbers: its world only
    assert len(table["other_starts"]) == 4  # derived from the map, driven by every set
    assert (out / "trials.csv").is_file() and (out / "table1.md").is_file()
    assert "paper mean" not in (out / "table1.md").read_text()  # the paper's numbers: its world


@pytest.mark.parametrize("name", [*GALLERY, "hailu2001"])
def test_derived_starts_are_free_spread_and_deterministic(name):
    world = load_map(name)
    walls = MultiLineString([[(a, b), (c, d)] for a, b, c, d in world.segments])
    poses = derived_starts(world) + derived_starts(world, near=False)
    assert derived_starts(world) + derived_starts(world, near=False) == poses
    assert len(derived_starts(world)) == 4
    g = world.goal
    for x, y, heading in poses:
        assert bool(world.contains_xy(x, y))
        assert walls.distance(Point(x, y)) > BODY_RADIUS + 0.1
        assert math.hypot(x - g.x, y - g.y) > g.radius
        assert reaches_goal(world, (x, y))
        assert math.isfinite(heading)
    assert len({(x, y) for x, y, _ in poses}) == len(poses)


def test_the_paper_world_keeps_its_hand_picked_poses_and_box():
    world = load_map("hailu2001")
    assert study_starts(world) == OTHER_STARTS
    assert [p for p, _ in starts_for(world)] == list(STARTS)
    assert obstacle_for(world) == OBSTACLE


def test_starts_listed_in_the_map_are_used_and_checked():
    doc = {
        "boundary": [[0, 0], [6, 0], [6, 3], [0, 3]],
        "start": {"x": 0.5, "y": 0.5},
        "goal": {"x": 5.5, "y": 2.5, "radius": 0.3},
        "starts": [[1.0, 2.0, 90], [3.0, 1.5]],
    }
    world = load_map(doc)
    assert map_starts(world) == ((1.0, 2.0, math.pi / 2), (3.0, 1.5, 0.0))
    for bad, match in (
        ([[0.1, 1.0, 0]], "starts\\[0\\].*body radius"),
        ([[1.0, "a", 0]], "starts\\[0\\].y"),
        ([[9.0, 1.0]], "starts\\[0\\]"),
        ([[1.0]], "starts\\[0\\]"),
        ("x", "starts"),
    ):
        with pytest.raises(MapError, match=match):
            load_map(doc | {"starts": bad})


@pytest.mark.parametrize("name", GALLERY)
def test_derived_obstacle_is_on_free_ground_and_keeps_the_goal_reachable(name):
    world = load_map(name)
    box = derived_obstacle(world)
    assert box is not None and derived_obstacle(world) == box
    poly = Polygon(box)
    assert world.free_polygon.contains(poly)
    s, g = world.start, world.goal
    assert poly.distance(Point(s.x, s.y)) > BODY_RADIUS
    assert poly.distance(Point(g.x, g.y)) > g.radius + BODY_RADIUS
    blocked = world.with_obstacle(box)
    assert reaches_goal(blocked) and not shapely.is_empty(poly)


def test_ablate_takes_a_map(tmp_path):
    out = tmp_path / "abl"
    assert (
        main(
            [
                "ablate",
                "--recipes",
                "reflex_only",
                "--sets",
                "1",
                "--trials",
                "1",
                "--map",
                "hailu2001_mirror",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["_map"] == "hailu2001_mirror"
    assert summary["_optimum"]["steps"] == optimum("hailu2001_mirror")["steps"]
    assert "paper, Table 1" not in (out / "summary.md").read_text()
    table = json.loads((out / "reflex_only" / "table1.json").read_text())
    assert "paper_map" not in table and table["map"] == "hailu2001_mirror"
    mirror = load_map("hailu2001_mirror")
    assert [s["start"] for s in table["other_starts"]] == [list(p) for p in study_starts(mirror)]


def test_generalise_takes_a_map(tmp_path):
    mirror = load_map("hailu2001_mirror")
    report = run_generalisation(
        "paper_map", sets=1, trials=1, out=tmp_path / "gen", noise_levels=(), map="hailu2001_mirror"
    )
    assert report["map"] == "hailu2001_mirror" and len(report["starts"]) == 8
    assert [s["near_learned_route"] for s in report["starts"]] == [True] * 4 + [False] * 4
    assert report["obstacle"] == derived_obstacle(mirror) != OBSTACLE
    assert (tmp_path / "gen" / "obstacle.png").is_file()
    assert "hailu2001_mirror" in (tmp_path / "gen" / "generalise.md").read_text()


def test_baseline_and_generalise_parsers_take_a_map():
    from symrl.cli import build_parser
    from symrl.learner.config import load_config
    from symrl.studies.baseline import make_env

    parser = build_parser()
    for argv in (["baseline", "ppo"], ["generalise"], ["ablate"]):
        assert parser.parse_args(argv).map == "hailu2001"
        assert parser.parse_args([*argv, "--map", "maze"]).map == "maze"
    env = make_env(load_config("ppo", ["env.map=two_doors"]), [0])  # the baselines' env: its map
    try:
        assert env.base_env.world.name == "two_doors"
    finally:
        env.close()
