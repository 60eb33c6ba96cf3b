"""Every accepted value is meant: numbers are numbers, a recipe says what the robot is told, map
headings are radians, a goal the robot can meet, flags that only make sense together, no empty
paths, and a controller driven in another map says so."""

from __future__ import annotations

import math

import pytest
import yaml

from symrl.cli import main
from symrl.learner.config import ConfigError, load_config
from symrl.learner.strict import MAX_MAGNITUDE
from symrl.world.worldmap import MapError, load_map


@pytest.mark.parametrize(
    ("override", "words"),
    [
        ("update.gamma=True", "not a boolean"),
        ('update.gamma="0.9"', "not a string"),
        ("env.robot.radius=true", "not a boolean"),
        ('reflex.d_a="0.5"', "not a string"),
        ("env.robot.n_sensors=true", "not a boolean"),
        ("env.robot.sonar_noise_std=1e308", "out of range"),
        ("trial_gradient.rate=1e308", "out of range"),
        ("options.reach=-1e300", "out of range"),
        ("reflex.peaks=[1]", "expected 3 numbers, got 1"),
        ("reflex.peaks=[0.1,true,0.2]", "not a boolean"),
        ("update.eta=nan", "finite"),
    ],
)
def test_a_number_key_takes_only_numbers_within_bounds(override, words):
    with pytest.raises(ConfigError) as err:
        load_config("paper", [override])
    message = str(err.value)
    assert "\n" not in message and words in message
    assert message.startswith(override.split("=")[0])  # the key named first


def test_numbers_at_the_bound_and_ints_for_floats_are_taken():
    assert load_config("paper", ["update.gamma=1"]).update.gamma == 1.0
    assert load_config("paper", [f"trial_gradient.rate={MAX_MAGNITUDE:g}"])


def test_a_recipe_declares_its_knowledge(tmp_path):
    recipe = tmp_path / "r.yaml"
    recipe.write_text("update:\n  gamma: 0.9\n")
    with pytest.raises(ConfigError, match="no knowledge: key"):
        load_config(recipe)
    recipe.write_text("knowledge: regions\nupdate:\n  gamma: 0.9\n")
    assert load_config(recipe).knowledge == "regions"


def test_the_option_source_is_blamed_for_its_rung():
    with pytest.raises(ConfigError, match=r"options.source=map \(with options.enabled=true\)"):
        load_config("paper", ["options.source=map"])


def _map(tmp_path, **changes):
    from importlib import resources

    data = yaml.safe_load((resources.files("symrl.world") / "maps" / "hailu2001.yaml").read_text())
    for key, value in changes.items():
        section, field = key.split("__")
        data[section][field] = value
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("heading", [270, -7.0, 1e9])
def test_a_start_heading_beyond_two_pi_is_refused_as_degrees(tmp_path, heading):
    with pytest.raises(MapError, match="radians") as err:
        load_map(_map(tmp_path, start__heading=heading))
    assert "absurdly" not in str(err.value)


def test_a_start_heading_in_radians_is_taken(tmp_path):
    assert load_map(_map(tmp_path, start__heading=-math.pi)).start.heading == -math.pi


@pytest.mark.parametrize("radius", [1e-9, 0.05])
def test_a_goal_radius_the_robot_cannot_meet_is_refused(tmp_path, radius):
    with pytest.raises(MapError, match="half the robot's"):
        load_map(_map(tmp_path, goal__radius=radius))


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "paper", "--logdir", ""],
        ["study", "paper", "--out", ""],
        ["drive", "--out", " "],
        ["sweep", "--recipes", "paper", "--seeds", "1", "--out", ""],
        ["evaluate", ""],
        ["ablate", "--base", "paper", "--recipes", "paper"],
        ["baseline", "sac", "--correction", "0.1"],
    ],
)
def test_empty_paths_and_lone_flags_are_refused(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "error:" in err


def test_evaluate_in_another_map_refuses_then_names_both(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["train", "reflex_only", "--trials", "1", "--logdir", str(run)]) == 0
    capsys.readouterr()
    ckpt = str(run / "checkpoint.pt")
    assert main(["evaluate", ckpt, "--map", "two_doors", "--out", str(tmp_path / "e")]) == 2
    err = capsys.readouterr().err
    assert "learned in map 'hailu2001'" in err and "--other-map" in err
    assert (
        main(["evaluate", ckpt, "--map", "two_doors", "--other-map", "--out", str(tmp_path / "e")])
        == 0
    )
    captured = capsys.readouterr()
    assert "trained on map 'hailu2001', driving in map 'two_doors'" in captured.err
    assert "trained on hailu2001, driven in two_doors" in captured.out
    # the map it learned in, named again, is no other map
    assert main(["evaluate", ckpt, "--map", "hailu2001", "--out", str(tmp_path / "f")]) == 0
    assert main(["evaluate", ckpt, "--other-map", "--out", str(tmp_path / "g")]) == 2


@pytest.mark.parametrize(
    ("boundary", "goal"),
    [
        ([[0, 0], [1.2, 0], [1.2, 9000], [0, 9000]], {"x": 0.6, "y": 3.0, "radius": 0.4}),
        ([[0, 0], [9000, 0], [9000, 1.2], [0, 1.2]], {"x": 3.0, "y": 0.6, "radius": 0.4}),
    ],
)
def test_a_very_tall_or_wide_map_renders_a_bounded_frame(tmp_path, boundary, goal):
    from symrl.world.env import Hailu2001Env

    start = {"x": goal["x"] if goal["x"] < 1 else 1.0, "y": 1.0 if goal["x"] < 1 else 0.6}
    path = tmp_path / "long.yaml"
    path.write_text(
        yaml.safe_dump({"name": "long", "boundary": boundary, "start": start, "goal": goal})
    )
    env = Hailu2001Env(map=str(path), render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame is not None and frame.ndim == 3
    assert 100 <= frame.shape[0] <= 1000 and 100 <= frame.shape[1] <= 1000  # never gigabytes
    assert (frame < 250).any()  # something is drawn: not an empty frame
