"""Typed run configuration: read and merged by OmegaConf, validated by pydantic.

A recipe (``recipes/<name>.yaml``) sets a few fields of :class:`RunConfig`; the defaults
are the literal rules of the paper (``docs/explanation/algorithm.md``), so a recipe lists only
what it changes. ``key=value`` overrides (``update.gamma=0.9``, each key once) are merged on top;
mappings merge entry by entry (``reflex.near`` keeps the sectors a recipe does not name), anything
else replaces. OmegaConf reads, parses and merges (so ``${shield.margin}`` refers to another key);
pydantic validates. Every error is one line naming the key and the value (:class:`ConfigError`).
The string under each field is its description (``symrl train --help-keys``).

The sections follow the data flow: ``env`` (world and robot) -> ``localize`` (the pose the
robot believes) -> ``gate`` (regions) ->
``experts`` (growing RBF networks) -> ``options`` (sub-goals for the reflex) -> ``reflex`` ->
``shield``; ``update`` is the TESEO learning rule,
``trial_gradient`` a second actor rule; ``run`` the budget.

The package's modules by job: :mod:`~symrl.learner.config.sections` (the sections),
:mod:`~symrl.learner.config.schema` (:class:`RunConfig` and the rules between its sections),
:mod:`~symrl.learner.config.recipes` (the recipe files), :mod:`~symrl.learner.config.merging`
(the layers merged), :mod:`~symrl.learner.config.loading` (validated, faults in one line) and
:mod:`~symrl.learner.config.keys` (``--help-keys``).
"""

from __future__ import annotations

from symrl.learner.config.keys import describe_keys
from symrl.learner.config.loading import apply_overrides, config_from_dict, load_config
from symrl.learner.config.recipes import MAX_RECIPE_BYTES as MAX_RECIPE_BYTES
from symrl.learner.config.recipes import builtin_recipes
from symrl.learner.config.schema import ConfigError, RunConfig, config_to_dict
from symrl.learner.config.sections import (
    CrossingsConfig,
    EnvConfig,
    ExpertsConfig,
    GateConfig,
    LocalizeSection,
    OptionCriticConfig,
    OptionsConfig,
    RunSection,
    ScanOdometrySection,
    ShieldSection,
    TrialGradientConfig,
    UpdateConfig,
)

__all__ = [
    "ConfigError",
    "EnvConfig",
    "GateConfig",
    "ExpertsConfig",
    "UpdateConfig",
    "TrialGradientConfig",
    "OptionsConfig",
    "OptionCriticConfig",
    "CrossingsConfig",
    "LocalizeSection",
    "ScanOdometrySection",
    "ShieldSection",
    "RunSection",
    "RunConfig",
    "load_config",
    "builtin_recipes",
    "config_to_dict",
    "config_from_dict",
    "describe_keys",
    "apply_overrides",
]
