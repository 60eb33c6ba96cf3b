"""The deep-RL baselines as recipes: their config keys, what their robot is told, ``symrl
train`` of them, and ``symrl baseline`` as a short way to the same runs."""

from __future__ import annotations

import pytest
import yaml

from symrl.cli import main
from symrl.learner.config import ConfigError, describe_keys, load_config


@pytest.mark.parametrize("algorithm, robots", [("sac", 1), ("ppo", 8)])
def test_the_baseline_recipes_declare_their_algorithm_and_knowledge(algorithm, robots):
    config = load_config(algorithm)
    assert config.baseline.algorithm == algorithm and config.knowledge == "sensors"
    assert config.baseline.robots == robots and config.baseline.bound == 0.25
    assert not config.baseline.residual and not config.baseline.regions
    assert load_config(algorithm, ["baseline.envs=3"]).baseline.robots == 3
    keys = describe_keys(config)
    for key in ("baseline.residual", "baseline.envs", f"baseline.{algorithm}.hidden"):
        assert f"  {key} = " in keys
    assert "baseline:" in describe_keys()  # listed without a recipe too


@pytest.mark.parametrize(
    "recipe, overrides, message",
    [
        ("sac", ["baseline.sac.hiden=3"], "baseline.sac.hiden=3: unknown key"),
        ("sac", ["baseline.envs=0"], "baseline.envs=0"),
        ("ppo", ["baseline.envs=2000"], "baseline.envs=2000"),
        ("sac", ["baseline.correction=1.5", "baseline.residual=true"], "baseline.correction=1.5"),
        ("sac", ["baseline.correction=0.1"], "baseline.correction=0.1: only with"),
        ("sac", ["baseline.algorithm=dqn"], "baseline.algorithm='dqn'"),
        ("ppo", ["baseline.ppo.lr=true"], "baseline.ppo.lr=True"),
        ("paper", ["baseline.residual=true"], "baseline.residual=true: only with"),
        ("sac", ["options.enabled=true", "knowledge=map"], "options.enabled=true"),
    ],
)
def test_a_bad_baseline_key_is_one_line_naming_it(recipe, overrides, message, capsys):
    with pytest.raises(ConfigError) as err:
        load_config(recipe, overrides)
    assert message in str(err.value) and len(str(err.value).splitlines()) == 1
    assert main(["train", recipe, *overrides, "--trials", "1"]) == 2
    out = capsys.readouterr().err.strip()
    assert len(out.splitlines()) == 1 and message in out


def test_the_region_one_hot_needs_the_region_rung():
    with pytest.raises(ConfigError, match="baseline.regions=true needs knowledge=regions"):
        load_config("sac", ["baseline.regions=true"])
    config = load_config("sac", ["baseline.regions=true", "knowledge=regions"])
    assert config.baseline.regions


def test_the_baseline_reads_the_regions_from_what_it_is_told():
    from symrl.knowledge.rungs import Knowledge
    from symrl.studies.baseline import make_env
    from symrl.world.worldmap import load_map

    world = load_map("hailu2001")
    told = Knowledge.told(world, "regions")
    config = load_config("ppo", ["baseline.regions=true", "knowledge=regions"])
    env = make_env(config, [0])
    transform = env.transform
    assert transform.n_regions == len(told.regions.names) > 1
    assert transform.regions.names == told.regions.names
    scratch = make_env(load_config("ppo"), [0]).transform
    assert scratch.regions is None  # a robot not told the rules gets no one-hot
    assert env.observation_spec["observation"].shape[-1] == (scratch.size + len(told.regions.names))
    env.close()


def test_train_of_a_baseline_recipe_is_the_alias_run(tmp_path):
    alias = tmp_path / "alias"
    argv = ["--residual", "--regions", "--envs", "2", "--episodes", "2", "--seeds", "7"]
    assert main(["baseline", "ppo", *argv, "--out", str(alias)]) == 0
    keys = ["baseline.residual=true", "baseline.regions=true", "knowledge=regions"]
    train = tmp_path / "train"
    argv = ["ppo", "--seed", "7", "--trials", "2", *keys, "baseline.envs=2"]
    assert main(["train", *argv, "--logdir", str(train)]) == 0
    table = (train / "trials.csv").read_bytes()
    assert (alias / "seed-7" / "trials.csv").read_bytes() == table
    assert len(table.splitlines()) == 3
    for folder in (train, alias / "seed-7"):
        assert {"config.yaml", "trials.csv", "tb", "checkpoint.pt"} <= {
            p.name for p in folder.iterdir()
        }
        recorded = yaml.safe_load((folder / "config.yaml").read_text())
        assert recorded["recipe"] == "ppo" and recorded["knowledge"] == "regions"
        assert recorded["baseline"]["regions"] is True and "sac" not in recorded["baseline"]
        assert "experts" not in recorded  # only what the baseline reads
    assert (alias / "summary.md").is_file() and (alias / "curves.png").is_file()
    assert main(["evaluate", str(train / "checkpoint.pt")]) == 0


def test_a_study_of_a_baseline_is_refused_in_one_line(tmp_path, capsys):
    for argv in (
        ["study", "sac", "--sets", "2", "--out", str(tmp_path / "s")],
        ["ablate", "--recipes", "paper,ppo", "--out", str(tmp_path / "a")],
        ["generalise", "--recipe", "sac", "--out", str(tmp_path / "g")],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "is a deep-RL baseline" in err, err
    assert not (tmp_path / "s").exists()


def test_a_sweep_trains_a_baseline_recipe_and_keeps_it(tmp_path, capsys):
    argv = ["sweep", "--recipes", "ppo", "--seeds", "1", "--trials", "1", "--out", str(tmp_path)]
    assert main(argv) == 0
    (run,) = (tmp_path / "runs").iterdir()
    assert len((run / "trials.csv").read_text().splitlines()) == 2
    capsys.readouterr()
    assert main(argv) == 0
    assert "(0 trained, 1 already finished)" in capsys.readouterr().out


def test_a_baseline_checkpoint_of_the_earlier_format_still_drives():
    """A PPO controller (residual, regions one-hot) saved before baselines were recipes: its
    algorithm and priors beside the map rung's config. It loads as a baseline told the regions
    rung and drives the greedy trial the code that wrote it drove (40 actions, -20.43)."""
    from pathlib import Path

    from symrl.studies.baseline_checkpoint import load_baseline

    path = Path(__file__).parent / "data" / "ppo_residual_regions_earlier.pt"
    controller = load_baseline(path)
    assert controller is not None
    config = controller.config
    assert config.baseline.algorithm == "ppo" and config.baseline.residual
    assert config.baseline.regions and config.knowledge == "regions"
    assert not (config.options.enabled or config.localize.enabled or config.gate.partition)
    (trial,) = controller.evaluate()
    assert trial["reached_goal"] and trial["steps"] == 40
    assert trial["total_reinforcement"] == pytest.approx(-20.43, abs=0.005)
