"""Recipes load, overrides apply, and bad input is rejected with the key and the value named."""

from __future__ import annotations

import pytest
import yaml

from symrl.knowledge.reflex import ReflexConfig
from symrl.learner.config import (
    ConfigError,
    RunConfig,
    builtin_recipes,
    config_from_dict,
    config_to_dict,
    load_config,
)

RECIPES = ["paper", "paper_literal", "no_partition", "no_reflex", "plain", "reflex_only"]


def test_every_recipe_is_shipped_and_loads():
    assert set(RECIPES) <= set(builtin_recipes())
    for name in RECIPES:
        assert load_config(name).recipe == name


def test_paper_literal_is_the_algorithm_defaults():
    c = load_config("paper_literal")
    assert config_to_dict(c)["learner"] == config_to_dict(RunConfig())["learner"]
    lc = c.learner
    assert (lc.width, lc.novelty_radius, lc.gamma, lc.eta, lc.beta, lc.kappa) == (
        0.1, 0.1, 0.95, 0.3, 0.2, 0.1,
    )  # fmt: skip
    assert (lc.error_threshold, lc.temperature0, lc.cooling, lc.temperature_min) == (
        2.0, 0.3, 0.85, 0.05,
    )  # fmt: skip
    assert c.run.trials == 20 and c.env.noise


def test_paper_keeps_the_architecture_and_the_budget():
    # `paper` started equal to paper_literal; its improvements are learner and reflex switches.
    paper, literal = load_config("paper"), load_config("paper_literal")
    assert paper.env == literal.env and paper.run == literal.run
    assert paper.learner.partition and paper.learner.reflex and paper.learner.learning
    assert literal.reflex == ReflexConfig()  # the ALGORITHM.md section 4 reflex
    # paper: softer avoidance behind the shield, the rules and other sectors unchanged
    assert paper.reflex.d_a == 0.5 and paper.reflex.rules == literal.reflex.rules
    assert paper.reflex.near["FL"] == paper.reflex.near["FR"] == (0.10, 0.35)
    assert paper.reflex.near["F"] == literal.reflex.near["F"]


def test_reflex_section_merges_entries_and_names_bad_values():
    c = load_config("paper_literal", ["reflex.near.F=[0.2, 0.6]", "reflex.d_g=0.25"])
    assert c.reflex.near["F"] == (0.2, 0.6) and c.reflex.near["L"] == ReflexConfig().near["L"]
    assert c.reflex.d_g == 0.25
    with pytest.raises(ConfigError, match=r"reflex: ReflexConfig.near\['F'\] must be"):
        load_config("paper_literal", ["reflex.near.F=[0.6, 0.2]"])
    with pytest.raises(ConfigError, match=r"reflex.near.F=\[0.1\]: expected a list of 2"):
        load_config("paper_literal", ["reflex.near.F=[0.1]"])
    with pytest.raises(ConfigError, match="no such sector"):
        load_config("paper_literal", ["reflex.near.XX=[0.1, 0.2]"])
    with pytest.raises(ConfigError, match=r"reflex.bogus=1: unknown key"):
        load_config("paper_literal", ["reflex.bogus=1"])


def test_the_policy_drives_with_the_recipe_reflex():
    from symrl.train import make_policy

    policy = make_policy(load_config("paper"))
    assert policy.reflex.config == load_config("paper").reflex
    assert make_policy(load_config("paper_literal")).reflex.config == ReflexConfig()


def test_ablation_switches():
    assert not load_config("no_partition").learner.partition
    assert not load_config("no_reflex").learner.reflex
    plain = load_config("plain").learner
    assert not plain.partition and not plain.reflex
    assert not load_config("reflex_only").learner.learning


def test_overrides_are_typed():
    c = load_config("paper_literal", ["learner.gamma=0.9", "env.noise=false", "learner.eta=1e-3",
                                      "run.trials=3", "learner.utility_init=zero"])  # fmt: skip
    assert c.learner.gamma == 0.9 and c.env.noise is False and c.learner.eta == 1e-3
    assert c.run.trials == 3 and c.learner.utility_init == "zero"
    assert isinstance(load_config("paper", ["learner.gamma=1"]).learner.gamma, float)


@pytest.mark.parametrize(
    "override, words",
    [
        ("learner.gama=0.9", ["learner.gama", "unknown"]),
        ("learnr.gamma=0.9", ["learnr", "unknown"]),
        ("learner.gamma=abc", ["learner.gamma", "abc"]),
        ("learner.partition=3", ["learner.partition", "3"]),
        ("run.trials=2.5", ["run.trials", "2.5"]),
        ("learner.utility_init=foo", ["learner.utility_init", "foo"]),
        ("learner.gamma=2", ["learner.gamma", "2"]),
        ("learner=3", ["learner", "mapping"]),
        ("gamma", ["gamma", "key=value"]),
    ],
)
def test_bad_override_names_key_and_value(override, words):
    with pytest.raises(ConfigError) as err:
        load_config("paper_literal", [override])
    for word in words:
        assert word in str(err.value)
    assert isinstance(err.value, ValueError)  # the CLI prints ValueErrors cleanly


def test_bad_recipe_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("learner:\n  novelty_radus: 0.2\n")
    with pytest.raises(ConfigError, match="learner.novelty_radus"):
        load_config(bad)
    typed = tmp_path / "typed.yaml"
    typed.write_text("env:\n  noise: maybe\n")
    with pytest.raises(ConfigError, match="env.noise='maybe'"):
        load_config(typed)
    good = tmp_path / "mine.yaml"
    good.write_text("learner:\n  novelty_radius: 0.3\n")
    c = load_config(good)
    assert c.recipe == "mine" and c.learner.novelty_radius == 0.3


def test_unknown_recipe_lists_the_known_ones():
    with pytest.raises(ConfigError, match="nope.*paper_literal"):
        load_config("nope")
    with pytest.raises(ConfigError, match="no such file"):
        load_config("missing/file.yaml")


def test_round_trip_through_dict():
    c = load_config("no_reflex", ["learner.gamma=0.8"])
    assert config_from_dict(config_to_dict(c), recipe="no_reflex") == c


def test_round_trip_through_yaml_keeps_the_reflex_and_lists():
    c = load_config("paper", ["learner.option_avoidance=[0.7, 0.5]"])
    text = yaml.safe_dump(config_to_dict(c))  # tuples must have become lists
    assert config_from_dict(yaml.safe_load(text), recipe="paper") == c
