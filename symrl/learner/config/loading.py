"""Loading a run's config: a recipe and its ``key=value`` overrides (or a saved config's dict)
merged, validated by pydantic, and every fault told in one line naming the key and the value
and, when a recipe file set it, the file.

OmegaConf reads the recipe file and the overrides and merges them
(:mod:`symrl.learner.config.merging`); pydantic fills in the defaults and validates. What is
left here is the one-line error messages.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from symrl.learner.config.merging import (
    ABSENT,
    container,
    is_complete,
    merge_layers,
    parse_overrides,
    value_at,
)
from symrl.learner.config.recipes import read_recipe, recipe_path
from symrl.learner.config.schema import ConfigError, RunConfig, config_to_dict


def _unknown(key: str, value: Any) -> str:
    """``key=value: unknown key``, with the nearest field name of its section if one is close;
    a mapping of a single entry is shown as its dotted key."""
    leaf = ""
    while isinstance(value, dict) and len(value) == 1:
        name, value = next(iter(value.items()))
        leaf += f".{name}"
    shown = key + leaf if isinstance(value, dict) else f"{key}{leaf}={value!r}"
    parts = key.split(".")
    section = value_at(config_to_dict(RunConfig()), ".".join(parts[:-1]))
    names = [f for f in section if f != "recipe"] if isinstance(section, dict) else []
    close = difflib.get_close_matches(parts[-1], names, n=1)
    hint = f"; did you mean {'.'.join([*parts[:-1], close[0]])}{leaf}?" if close else ""
    return f"{shown}: unknown key{hint} (`symrl train --help-keys` lists them all)"


def _one_line(err: ValidationError) -> tuple[str, str]:
    """The first pydantic error as (dotted key, ``key=value: reason``)."""
    first = err.errors()[0]
    key = ".".join(str(p) for p in first["loc"])
    value = first.get("input")
    reason = first["msg"].removeprefix("Value error, ")
    if first["type"] in ("extra_forbidden", "unexpected_keyword_argument"):
        return key, _unknown(key, value)
    if isinstance(value, dict) or not key:
        return key, f"{key or 'config'}: {reason}"
    return key, f"{key}={value!r}: {reason}"


class _NumberFault(Exception):
    """A number key given a boolean, a string or an overflowing value (``symrl.learner.strict``)."""


def _validate(
    layers: list[tuple[str, Any]], recipe: str | None, merged: dict[str, Any] | None = None
) -> RunConfig:
    """Merge ``layers`` over the defaults (unless ``merged`` is given) and validate; an error
    names the layer that set the bad key when it is a recipe file (an override's message
    already shows its key and value)."""
    merged = merge_layers(layers) if merged is None else merged
    if recipe is not None:
        merged["recipe"] = recipe
    from symrl.learner.strict import number_fault

    fault = number_fault(RunConfig, merged)  # no bool or string for a number, no 1e308
    try:
        if fault is not None:
            raise _NumberFault()
        return RunConfig.model_validate(merged)
    except ValidationError as err:
        key, message = _one_line(err)
    except _NumberFault:
        key, message = fault  # type: ignore[misc]
    for source, data in reversed(layers):
        if key and value_at(container(data), key, ABSENT) is not ABSENT:
            if source.startswith("recipe "):
                message = f"{source}: {message}"
            break
    raise ConfigError(message) from None


def config_from_dict(data: dict[str, Any], recipe: str | None = None) -> RunConfig:
    """Build a validated RunConfig from a nested dict merged over the defaults."""
    if not isinstance(data, dict):
        raise ConfigError(f"config: expected a mapping of sections, got {data!r}")
    if is_complete(data):  # nothing to merge: pydantic fills in any missing field
        return _validate([("config", data)], recipe, merged=dict(data))
    return _validate([("config", data)], recipe)


def load_config(
    recipe: str | Path = "paper_literal", overrides: list[str] | tuple[str, ...] | None = None
) -> RunConfig:
    """Load a recipe by name or path and apply ``key=value`` overrides (dotted keys, each key
    once; values read as YAML)."""
    name, path = recipe_path(recipe)
    data = read_recipe(str(recipe), path)
    layers = [(f"recipe {str(recipe)!r}", data)]
    layers += [(text, nested) for text, _, nested in parse_overrides(overrides or [])]
    declared = "knowledge" in data
    config: RunConfig | None = None
    try:
        config = _validate(layers, recipe=str(data.get("recipe", name)))
    except ConfigError as err:  # a rung fault of a recipe that declares none: the missing key
        if declared or "needs knowledge=" not in str(err):
            raise
    if not declared:  # what the robot is told is never left to a default
        if config is not None:  # any fault of the map it names first, as a declared one's
            from symrl.world.worldmap import load_map

            load_map(config.env.map)
        raise ConfigError(
            f"recipe {str(recipe)!r}: no knowledge: key; every recipe declares what the robot "
            "is told (knowledge: sensors, regions, passages or map)"
        )
    assert config is not None
    return config


def apply_overrides(config: RunConfig, overrides: list[str] | tuple[str, ...]) -> RunConfig:
    """``config`` with ``key=value`` overrides applied (validated again)."""
    layers: list[tuple[str, Any]] = [("config", config_to_dict(config))]
    layers += [(text, nested) for text, _, nested in parse_overrides(overrides)]
    return _validate(layers, recipe=config.recipe)
