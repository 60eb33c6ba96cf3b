"""The training loop end to end: every recipe from the CLI, determinism, checkpoints, specs."""

from __future__ import annotations

import csv

import pytest
import torch

from symrl.cli import main
from symrl.learner.config import load_config
from symrl.train import evaluate, load_checkpoint, make_env, train

RECIPES = ["paper", "paper_literal", "no_partition", "no_reflex", "plain", "reflex_only"]
SHORT = ["env.max_actions=40"]  # keeps the random-action recipes fast


def _scalars(trials):
    drop = {"wall_time", "path", "ghosts"}
    return [{k: v for k, v in t.items() if k not in drop} for t in trials]


def test_wrapped_env_specs():
    from torchrl.envs.utils import check_env_specs

    env = make_env(load_config("paper_literal"))
    check_env_specs(env, seed=0)
    td = env.reset()
    assert td["true_pose"].dtype == torch.float64 and td["collision"].dtype == torch.bool


@pytest.mark.parametrize("recipe", RECIPES)
def test_every_recipe_trains_from_the_command_line(recipe, tmp_path, capsys):
    out = tmp_path / recipe
    assert main(["train", recipe, "--trials", "2", "--logdir", str(out), *SHORT]) == 0
    for name in ("trials.csv", "config.yaml", "checkpoint.pt", "trajectory.png"):
        assert (out / name).is_file(), name
    assert list((out / "tb").glob("events.out.tfevents.*"))
    with open(out / "trials.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["trial"] for r in rows] == ["1", "2"]
    assert {"steps", "total_reinforcement", "collisions", "reached_goal", "neurons",
            "temperature", "wall_time", "path_length"} <= set(rows[0])  # fmt: skip
    assert recipe in capsys.readouterr().out
    if recipe == "reflex_only":
        assert rows[-1]["neurons"] == "0"


def test_bad_override_is_a_clean_cli_error(tmp_path, capsys):
    assert main(["train", "paper", "learner.gama=1", "--logdir", str(tmp_path)]) == 2
    assert "learner.gama" in capsys.readouterr().err


def test_same_seed_same_trials_table():
    config = load_config("paper_literal", ["run.trials=3", "run.seed=7"])
    a = train(config, progress=False).trials
    b = train(config, progress=False).trials
    assert _scalars(a) == _scalars(b)
    assert [t["path"] for t in a] == [t["path"] for t in b]
    c = train(load_config("paper_literal", ["run.trials=3", "run.seed=8"]), progress=False)
    assert _scalars(c.trials) != _scalars(a)


def test_trial_records(tmp_path):
    result = train(load_config("paper_literal", ["run.trials=2"]), progress=False)
    for n, t in enumerate(result.trials, 1):
        assert t["trial"] == n and t["steps"] == len(t["path"]) - 1
        assert t["neurons"] == sum(t[f"neurons_{r}"] for r in result.policy.expert_names)
        assert 1 <= len(t["ghosts"]) <= t["steps"]
    assert result.trials[0]["temperature"] == pytest.approx(0.3)
    assert result.trials[1]["temperature"] == pytest.approx(0.3 * 0.85)


def test_checkpoint_round_trip_gives_the_same_greedy_trajectory(tmp_path):
    out = tmp_path / "run"
    train(load_config("paper_literal", ["run.trials=2"]), logdir=out, progress=False)
    policy, config = load_checkpoint(out / "checkpoint.pt")
    again, _ = load_checkpoint(out / "checkpoint.pt")
    assert policy.neurons() == again.neurons() and policy.total_neurons() > 0
    a = evaluate(policy, seed=3, config=config)
    b = evaluate(out / "checkpoint.pt", seed=3)
    assert a["path"] == b["path"] and a["total_reinforcement"] == b["total_reinforcement"]
    assert policy.neurons() == again.neurons()  # greedy evaluation grows nothing


def test_checkpoint_keeps_the_recipe_reflex_and_shield(tmp_path):
    out = tmp_path / "run"
    config = load_config("paper", ["run.trials=1"])
    train(config, logdir=out, progress=False)
    policy, loaded = load_checkpoint(out / "checkpoint.pt")
    assert loaded.reflex == config.reflex and policy.reflex.config == config.reflex
    assert policy.shield is not None and policy.options is not None


def test_evaluate_command(tmp_path, capsys):
    out = tmp_path / "run"
    train(load_config("paper_literal", ["run.trials=1"]), logdir=out, progress=False)
    code = main(["evaluate", str(out / "checkpoint.pt"), "--start", "0,0.5,0", "--out", str(out)])
    assert code == 0 and (out / "evaluate.png").is_file()
    assert "greedy trial" in capsys.readouterr().out


def test_trials_csv_takes_the_union_of_columns(tmp_path):
    from symrl.train import write_trials_csv

    write_trials_csv(
        tmp_path / "t.csv",
        [{"trial": 1, "steps": 30, "path": [(0, 0)]}, {"trial": 2, "steps": 31, "extra": 0.5}],
    )
    with open(tmp_path / "t.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert rows == [
        {"trial": "1", "steps": "30", "extra": ""},
        {"trial": "2", "steps": "31", "extra": "0.5"},
    ]
