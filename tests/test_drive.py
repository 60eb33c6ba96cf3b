"""The reflex alone drives the robot to the goal (docs/explanation/algorithm.md §4); `symrl drive`
reports it."""

from __future__ import annotations

import json
import math

import pytest
import torch

from symrl.cli import main
from symrl.drive import drive
from symrl.knowledge import RegionMapper


@pytest.fixture(scope="module")
def clean_trial():
    return drive(noise=False)


def test_reflex_reaches_the_goal_without_noise(clean_trial):
    assert clean_trial["reached_goal"]
    assert clean_trial["steps"] < 60  # docs/explanation/algorithm.md measured 32; the budget is 200
    assert clean_trial["total_reinforcement"] < 0
    assert clean_trial["start"] == [0.0, 0.0, 0.0]


def test_reflex_is_caught_by_the_concave_region_then_finds_the_door(clean_trial):
    # the paper's story of the reflex alone: head for the goal, drop below l1 into the
    # concave region, climb back and pass the door into the corridor
    mapper = RegionMapper.from_map("hailu2001")
    ids = mapper(torch.tensor(clean_trial["odometry_path"])).tolist()
    visited = [ids[0]] + [b for a, b in zip(ids, ids[1:], strict=False) if a != b]
    assert [mapper.names[i] for i in visited] == ["room", "concave", "room", "door", "corridor"]


def test_reflex_trial_is_deterministic_without_noise(clean_trial):
    again = drive(noise=False, seed=7)
    assert again["path"] == clean_trial["path"]
    assert again["total_reinforcement"] == clean_trial["total_reinforcement"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_reflex_reaches_the_goal_with_noise(seed):
    result = drive(seed=seed, noise=True)
    assert result["reached_goal"]
    assert result["steps"] < 200
    assert result == drive(seed=seed, noise=True)  # same seed, same trial


def test_result_is_consistent(clean_trial):
    r = clean_trial
    assert r["steps"] == len(r["actions"]) == len(r["path"]) - 1
    assert all(-math.pi <= a <= math.pi for a in r["actions"])
    # every move is 0.20 m except the ones undone by the emergency handler
    assert r["path_length"] == pytest.approx(0.2 * (r["steps"] - r["collisions"]), abs=1e-6)
    gx, gy = 4.0, -2.0
    x, y = r["path"][-1]
    assert math.hypot(x - gx, y - gy) <= 0.40


def test_drive_from_another_start():
    result = drive(start=(1.0, 1.5, 3.0), noise=False)
    assert result["start"] == pytest.approx([1.0, 1.5, 3.0])
    assert result["path"][0] == pytest.approx((1.0, 1.5))
    assert result["reached_goal"]


def test_cli_drive_saves_png_and_prints_the_numbers(tmp_path, capsys, clean_trial):
    out = tmp_path / "drive"
    assert main(["drive", "--no-noise", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    png = out / "path.png"
    assert png.exists()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    saved = json.loads((out / "trial.json").read_text())
    assert saved["steps"] == clean_trial["steps"]
    assert saved["reached_goal"] is True
    assert f"steps: {clean_trial['steps']} " in printed
    assert f"collisions: {clean_trial['collisions']} " in printed
    assert f"total reinforcement: {clean_trial['total_reinforcement']:.2f} " in printed
    assert "reached goal: yes" in printed


def test_cli_drive_start_and_seed(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["drive", "--start", "1,1.5,180", "--seed", "3", "--out", str(out)]) == 0
    saved = json.loads((out / "trial.json").read_text())
    assert saved["seed"] == 3
    assert saved["noise"] is True
    assert saved["start"][:2] == pytest.approx([1.0, 1.5])
    expected = drive(start=(1.0, 1.5, math.pi), seed=3)
    assert f"steps: {expected['steps']} " in capsys.readouterr().out


def test_cli_drive_bad_start_is_a_clear_error(tmp_path, capsys):
    # (3.6, 1.0) is inside the dividing wall
    assert main(["drive", "--start", "3.6,1.0,0", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("symrl drive: error:")
    assert not (tmp_path / "path.png").exists()


def test_the_ir_shield_keeps_the_reflex_off_the_walls():
    from symrl.knowledge.shield import ShieldConfig

    plain = drive(seed=1)
    guarded = drive(seed=1, shield=ShieldConfig())
    assert plain["collisions"] > 0 and plain["shielded"] == 0  # seed 1: the reflex hits a post
    assert guarded["collisions"] == 0 and guarded["shielded"] > 0
    assert guarded["reached_goal"]


def test_drive_cli_shield_flag(tmp_path, capsys):
    assert main(["drive", "--seed", "1", "--shield", "--out", str(tmp_path)]) == 0
    assert "collisions: 0" in capsys.readouterr().out
    assert main(["drive", "--shield", "-1", "--out", str(tmp_path)]) == 2
    assert "ShieldConfig.margin" in capsys.readouterr().err
