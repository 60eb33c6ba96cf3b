"""Recipes load, overrides merge, and bad input is one line naming the key and the value."""

from __future__ import annotations

import math
import re
from importlib import resources

import pytest
import torch
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig
from symrl.learner.config import (
    ConfigError,
    RunConfig,
    apply_overrides,
    builtin_recipes,
    config_from_dict,
    config_to_dict,
    describe_keys,
    load_config,
)
from symrl.world.robot import RobotConfig

RECIPES = ["paper_map", "paper_literal", "no_partition", "no_reflex", "plain", "reflex_only"]


@pytest.mark.parametrize("name", RECIPES)
def test_every_recipe_is_shipped_and_loads(name):
    assert name in builtin_recipes()
    config = load_config(name)
    assert isinstance(config, RunConfig) and config.recipe == name


def test_paper_literal_is_the_defaults():
    literal = load_config("paper_literal")
    assert config_to_dict(literal) == config_to_dict(RunConfig())
    u, x = literal.update, literal.experts
    assert (x.width, x.novelty_radius, u.gamma, u.eta, u.beta, u.kappa) == (
        0.1,
        0.1,
        0.95,
        0.3,
        0.2,
        0.1,
    )
    assert (u.error_threshold, u.temperature0, u.cooling, u.temperature_min) == (
        2.0,
        0.3,
        0.85,
        0.05,
    )
    assert not literal.options.enabled and not literal.shield.enabled
    assert not literal.experts.residual and literal.reflex == ReflexConfig()


def test_paper_sets_its_switches_and_keeps_the_budget():
    paper, literal = load_config("paper_map"), load_config("paper_literal")
    assert paper.env == literal.env and paper.run == literal.run
    assert paper.gate.partition and paper.experts.reflex and paper.experts.learning
    assert paper.experts.residual
    assert (paper.update.temperature0, paper.update.temperature_min) == (0.1, 0.0)
    o = paper.options
    assert o.enabled and o.source == "map" and o.region_limit == 20
    assert paper.option_critic.critic == "mean" and paper.option_critic.try_untried
    assert o.goal_lead_deg == 0.0 and load_config("paper").options.goal_lead_deg == 20.0
    assert literal.options.region_limit is None
    assert paper.shield.enabled and paper.shield.margin == 0.06
    # softer avoidance behind the shield; the rules and the other sectors unchanged
    assert paper.reflex.d_a == 0.5 and paper.reflex.rules == literal.reflex.rules
    assert paper.reflex.near["FL"] == paper.reflex.near["FR"] == (0.10, 0.30)
    assert paper.reflex.near["F"] == literal.reflex.near["F"]


def test_paper_reflex_ignores_a_wall_alongside_that_the_literal_reflex_swerves_from():
    sonar = torch.ones(24, dtype=torch.float64)
    sonar[[20, 21, 22]] = 0.4 / 5.0  # a wall 0.4 m away, front-right
    literal = FuzzyReflex(ReflexConfig()).angle(sonar, 0.0)
    paper = FuzzyReflex(load_config("paper_map").reflex)
    assert literal > math.radians(10)  # FR near -> LEFT: a turn away from a harmless wall
    assert paper.angle(sonar, 0.0) == pytest.approx(0.0)  # the goal straight ahead wins
    sonar[[20, 21, 22]] = 0.15 / 5.0  # closer than 0.30 m: the paper reflex avoids it too
    assert paper.angle(sonar, 0.0) > math.radians(10)


def test_ablation_switches():
    assert not load_config("no_partition").gate.partition
    assert not load_config("no_reflex").experts.reflex
    plain = load_config("plain")
    assert not plain.gate.partition and not plain.experts.reflex
    assert not load_config("reflex_only").experts.learning


def test_overrides_are_typed_and_merge():
    c = load_config(
        "paper_literal",
        [
            "update.gamma=0.9",
            "env.noise=false",
            "update.eta=1e-3",
            "run.trials=3",
            "option_critic.critic=best",
            "env.robot.radius=0.3",
        ],
    )
    assert c.update.gamma == 0.9 and c.env.noise is False and c.update.eta == 1e-3
    assert c.run.trials == 3 and c.option_critic.critic == "best"
    assert isinstance(c.env.robot, RobotConfig) and c.env.robot.radius == 0.3
    assert c.env.robot.step == RobotConfig().step  # the other robot fields are kept
    assert isinstance(load_config("paper_map", ["update.gamma=1"]).update.gamma, float)


def test_reflex_mappings_merge_entry_by_entry():
    c = load_config("paper_literal", ["reflex.near.FL=[0.1, 0.3]", "reflex.d_g=0.25"])
    default = ReflexConfig().near
    assert c.reflex.near["FL"] == (0.1, 0.3)
    assert {k: v for k, v in c.reflex.near.items() if k != "FL"} == {
        k: v for k, v in default.items() if k != "FL"
    }
    assert c.reflex.d_g == 0.25
    # over a recipe that sets FL and FR itself, FR is kept
    paper = load_config("paper_map", ["reflex.near.FL=[0.1, 0.35]"])
    assert paper.reflex.near["FR"] == (0.10, 0.30) and paper.reflex.near["FL"] == (0.1, 0.35)


def _error(overrides: list[str], recipe: str = "paper_literal") -> str:
    with pytest.raises(ConfigError) as err:
        load_config(recipe, overrides)
    assert isinstance(err.value, ValueError)  # the CLI prints ValueErrors as one clean line
    message = str(err.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize(
    "override, words",
    [
        ("bogus=1", ["bogus", "unknown key"]),  # top level
        ("update.gama=0.9", ["update.gama", "0.9", "unknown key"]),  # nested
        ("env.robot.radus=1", ["env.robot.radus", "unknown key"]),  # two levels down
        ("reflex.bogus=1", ["reflex.bogus", "unknown key"]),
        ("run.seed=true", ["run.seed", "true"]),  # a bool is not an int
        ("env.max_actions=1e9", ["env.max_actions", "1000000000"]),  # a float is not an int
        ("run.trials=2.5", ["run.trials", "2.5"]),
        ("update.gamma=abc", ["update.gamma", "abc"]),
        ("gate.partition=3", ["gate.partition", "3"]),
        ("option_critic.critic=max", ["option_critic.critic", "max"]),
        ("update.gamma=2", ["update.gamma", "2", "less than or equal to 1"]),  # out of range
        ("experts.width=0", ["experts.width", "0", "greater than 0"]),
        ("shield.margin=-0.1", ["shield.margin", "-0.1"]),
        ("option_critic.epsilon=1.5", ["option_critic.epsilon", "1.5"]),
        ("options.goal_lead_deg=-5", ["options.goal_lead_deg", "-5"]),
        ("options.ahead=0", ["options.ahead", "0"]),
        ("options.region_limit=0", ["options.region_limit", "0"]),
        ("update.eta=nan", ["update.eta", "nan", "finite"]),
        ("update.beta=.inf", ["update.beta", "inf", "finite"]),
        ("env.robot.radius=-1", ["env.robot", "radius", "-1"]),
        ("update=3", ["update", "3"]),
        ("update=[1, 2]", ["update=[1, 2]"]),  # a section is a mapping
        ("reflex.near.FL={a: 1}", ["reflex.near.FL", "'a': 1", "a mapping and a list"]),
        ("updte.gamma=0.9", ["updte.gamma=0.9", "unknown key", "did you mean update.gamma?"]),
        ("update.gama=0.9", ["update.gama=0.9", "unknown key", "did you mean update.gamma?"]),
        ("update.gamma=[1,", ["update.gamma=[1,", "not a valid yaml value"]),
        ("options.reach=${nope.x}", ["options.reach", "${nope.x}", "not found"]),
        ("update.=1", ["update.=1", "empty key"]),
        ("gamma", ["gamma", "key=value"]),
    ],
)
def test_bad_override_is_one_line_naming_key_and_value(override, words):
    message = _error([override]).lower()
    for word in words:
        assert word.lower() in message, (word, message)


def test_cross_field_rules():
    message = _error(["experts.residual=true", "experts.reflex=false"])
    assert "experts.residual" in message and "experts.reflex" in message
    # the paper recipe has residual experts: turning the reflex off alone is refused too
    assert "experts.residual" in _error(["experts.reflex=false"], recipe="paper_map")
    message = _error(["experts.capacity=10", "experts.max_neurons=5"])
    assert "experts.max_neurons=5" in message and "experts.capacity=10" in message


def test_bad_recipe_files(tmp_path):
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("knowledge: regions\nexperts:\n  novelty_radus: 0.2\n")
    with pytest.raises(ConfigError, match="unknown.yaml.*experts.novelty_radus=0.2: unknown key"):
        load_config(unknown)
    typed = tmp_path / "typed.yaml"
    typed.write_text("knowledge: regions\nenv:\n  noise: maybe\n")
    with pytest.raises(ConfigError, match="typed.yaml.*env.noise='maybe'"):
        load_config(typed)
    with pytest.raises(ConfigError, match="^env.noise='perhaps'"):  # the override is named
        load_config(typed, ["env.noise=perhaps"])
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    with pytest.raises(ConfigError, match="empty.yaml.*non-empty mapping"):
        load_config(empty)
    twice = tmp_path / "twice.yaml"
    twice.write_text("update:\n  gamma: 0.9\n  gamma: 0.8\n")
    with pytest.raises(ConfigError, match="twice.yaml.*line 3.*duplicate key gamma") as err:
        load_config(twice)
    assert "\n" not in str(err.value)
    listed = tmp_path / "listed.yaml"
    listed.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="listed.yaml"):
        load_config(listed)
    silent = tmp_path / "silent.yaml"  # what the robot is told is never a default
    silent.write_text("experts:\n  novelty_radius: 0.3\n")
    with pytest.raises(ConfigError, match="silent.yaml.*no knowledge: key"):
        load_config(silent)
    with pytest.raises(ConfigError, match="no knowledge: key"):  # not even given as override
        load_config(silent, ["knowledge=regions"])
    good = tmp_path / "mine.yaml"
    good.write_text("knowledge: regions\nexperts:\n  novelty_radius: 0.3\n")
    c = load_config(good)
    assert c.recipe == "mine" and c.experts.novelty_radius == 0.3


def test_missing_and_unknown_recipes():
    with pytest.raises(ConfigError, match="nope.*unknown.*paper_literal"):
        load_config("nope")
    with pytest.raises(ConfigError, match="missing/file.yaml.*no such file"):
        load_config("missing/file.yaml")


@pytest.mark.parametrize("name", RECIPES)
def test_round_trip_through_a_dict(name):
    c = load_config(name, ["update.gamma=0.8", "reflex.near.F=[0.2, 0.6]"])
    assert config_from_dict(config_to_dict(c)) == c


def test_round_trip_through_yaml():
    c = load_config("paper_map", ["env.robot.radius=0.3"])
    text = yaml.safe_dump(config_to_dict(c))  # tuples must have become lists
    assert config_from_dict(yaml.safe_load(text)) == c


def test_config_from_dict_merges_a_partial_dict_over_the_defaults():
    c = config_from_dict({"reflex": {"near": {"FL": [0.1, 0.3]}}, "run": {"seed": 4}})
    assert c.reflex.near["FL"] == (0.1, 0.3) and c.reflex.near["F"] == ReflexConfig().near["F"]
    assert c.run.seed == 4 and c.run.trials == RunConfig().run.trials
    assert config_from_dict({"options": {"reach": "${shield.margin}"}}).options.reach == 0.06
    # a checkpoint's config that lacks a later field: its default
    old = config_to_dict(load_config("paper"))
    del old["update"]["gamma"], old["trial_gradient"]
    c = config_from_dict(old)
    assert c.update.gamma == 0.95 and c.trial_gradient == RunConfig().trial_gradient
    assert c.update.temperature0 == load_config("paper").update.temperature0


def test_config_from_dict_rejects_a_non_mapping():
    with pytest.raises(ConfigError, match="mapping"):
        config_from_dict([1, 2])  # type: ignore[arg-type]


def test_describe_keys_lists_every_section():
    text = describe_keys()
    for key in (
        "update.gamma = 0.95",
        "experts.novelty_radius",
        "env.robot.radius",
        "option_critic.critic",
        "options.ahead",
        "shield.margin",
        "reflex.d_a",
        "run.seed",
        "localize.enabled",
        "localize.prior_xy",
    ):
        assert key in text, key
    assert "Discount of the TD error" in text  # each key's docstring


@pytest.mark.parametrize(
    "override, keys",
    [
        ("env.robot.n_sensors=16", ["env.robot.n_sensors", "reflex.n_rays"]),
        ("env.robot.sonar_range=3", ["env.robot.sonar_range", "reflex.sonar_range"]),
    ],
)
def test_the_reflex_reads_the_robots_sonars(override, keys):
    """The reflex turns the observation's normalised sonars back into metres with its own
    ray count and range: a robot with other sonars must be refused when the config loads (a
    count mismatch fails only in the first trial, a range mismatch silently misreads every
    distance)."""
    message = _error([override])
    for key in keys:
        assert key in message, message


def test_every_public_name_of_the_learner_package_resolves():
    import symrl.learner

    missing = []
    for name in symrl.learner.__all__:
        try:
            getattr(symrl.learner, name)
        except AttributeError:
            missing.append(name)
    assert not missing, f"symrl.learner.__all__ names what does not exist: {missing}"


def test_bad_localisation_settings_are_named():
    assert "localize.iterations" in _error(["localize.iterations=0"])
    assert "localize.prior_xy" in _error(["localize.prior_xy=-1"])
    assert "localize.enabled" in _error(["localize.enabled=sometimes"])
    assert "search" in _error(["search.enabled=true"])  # the removed goal search is unknown


def _leaves(data: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(_leaves(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


@pytest.mark.parametrize("name", builtin_recipes())
def test_a_recipe_is_its_file_merged_over_the_defaults_entry_by_entry(name):
    """Every value the recipe file names, and the defaults for everything else (inside a mapping
    such as ``reflex.near`` too)."""
    text = (resources.files("symrl.recipes") / f"{name}.yaml").read_text()
    expected = _leaves(config_to_dict(RunConfig())) | _leaves(yaml.safe_load(text))
    expected["recipe"] = name
    assert _leaves(config_to_dict(load_config(name))) == expected


def test_a_key_given_twice_and_the_recipe_name_are_refused():
    message = _error(["update.gamma=0.9", "run.seed=3", "update.gamma=0.8"])
    assert message.startswith("update.gamma=0.8: ") and "already set by update.gamma=0.9" in message
    message = _error(["update={gamma: 0.9}", "update.gamma=0.8"])  # one inside the other
    assert "update.gamma=0.8" in message and "update={gamma: 0.9}" in message
    assert "update.gamma" in _error(["update.gamma=0.8", "update={gamma: 0.9}"])
    assert "recipe=mine" in _error(["recipe=mine"])
    with pytest.raises(ConfigError, match="recipe=mine"):
        apply_overrides(load_config("paper"), ["recipe=mine"])
    # keys that only share a prefix of their names are different keys
    c = load_config("paper", ["option_critic.epsilon=0.5", "option_critic.epsilon_decay=0.5"])
    assert (c.option_critic.epsilon, c.option_critic.epsilon_decay) == (0.5, 0.5)


_DISTINCT = [
    "update.gamma=0.9",
    "reflex.near.FL=[0.1, 0.3]",
    "reflex.near.F=[0.2, 0.6]",
    "env.robot.radius=0.3",
    "options.region_limit=25",
    "run.seed=5",
]


@settings(max_examples=15, deadline=None)
@given(st.permutations(_DISTINCT))
def test_the_order_of_distinct_overrides_does_not_matter(overrides):
    assert load_config("paper", overrides) == load_config("paper", _DISTINCT)


def test_apply_overrides_equals_loading_with_them():
    assert apply_overrides(load_config("paper"), _DISTINCT) == load_config("paper", _DISTINCT)


def test_overrides_may_refer_to_other_keys():
    c = load_config("paper", ["options.reach=${shield.margin}"])
    assert c.options.reach == c.shield.margin == 0.06
    # a key the recipe does not set: its default
    c = load_config(
        "paper_literal", ["options.reach=${shield.margin}", "update.eta=${update.beta}"]
    )
    assert (c.options.reach, c.update.eta) == (0.06, 0.2)
    assert "options.reach=${nope: " in _error(["options.reach=${nope"])
    assert "Recursive" in _error(["options.reach=${options.reach}"])


def test_help_keys_show_the_recipes_values_and_every_keys_meaning():
    paper = describe_keys(load_config("paper", ["update.gamma=0.5"]))
    assert "recipe 'paper'" in paper
    assert "update.temperature0 = 0.1  (default 0.3)" in paper  # the recipe's value
    assert "update.gamma = 0.5  (default 0.95)" in paper  # an override's
    assert "update.eta = 0.3\n" in paper  # a key the recipe keeps
    rows = paper.splitlines()
    keys = [re.match(r"  (\S+) = ", row) for row in rows]
    shown = [key.group(1) for key in keys if key]
    mappings = ("reflex.near.", "reflex.sectors.")  # shown whole
    expected = {
        k.rsplit(".", 1)[0] if k.startswith(mappings) else k
        for k in _leaves(config_to_dict(RunConfig()))
        if k != "recipe"
    }
    assert sorted(shown) == sorted(expected)  # every key once
    undocumented = [
        key.group(1)
        for key, after in zip(keys, [*rows[1:], ""], strict=True)
        if key and not after.startswith("      ")
    ]
    assert not undocumented, undocumented  # every key says what it means


def test_train_help_keys_with_a_recipe(capsys):
    from symrl.cli import main

    assert main(["train", "paper_map", "--help-keys"]) == 0
    out = capsys.readouterr().out
    assert out == describe_keys(load_config("paper_map")) + "\n"
    assert "update.temperature0 = 0.1  (default 0.3)" in out
    assert main(["train", "paper", "update.gama=1", "--help-keys"]) == 2
    assert "update.gama=1: unknown key" in capsys.readouterr().err
