"""What an ablation compares: the recipes of ``symrl ablate``, the knowledge ladder, and the
variants of one recipe with each of its settings put back to a base recipe's
(``--changes-of``)."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from pydantic import BaseModel

LADDER = ("reflex_only", "paper_literal", "paper", "paper_passages", "paper_map")
"""``symrl ablate --ladder``: the best recipe of each knowledge rung, and the paper's literal
learner, on the same seeds."""

RECIPES = (
    "paper",
    "paper_passages",
    "paper_map",
    "paper_literal",
    "no_partition",
    "no_reflex",
    "plain",
    "reflex_only",
)

# what a change ablation leaves alone: the recipe's name, and the budget, seed and logging
_NOT_CHANGES = ("recipe", "run.")


@dataclasses.dataclass(frozen=True)
class Variant:
    """One row of an ablation: ``recipe`` with ``overrides``, run and written as ``name``.
    ``change``: the setting put back (``"key: recipe value -> base value"``), if any."""

    name: str
    recipe: str
    overrides: tuple[str, ...] = ()
    change: str | None = None


def leaves(config: Any) -> dict[str, Any]:
    """Every setting of a config as dotted key -> plain value (as ``config_to_dict`` writes it:
    tuples as lists). Sections recurse; a setting whose value is a dict or a list, such as
    ``reflex.near``, is one setting."""
    from symrl.learner.config import config_to_dict

    out: dict[str, Any] = {}

    def walk(node: Any, plain: Any, prefix: str) -> None:
        if isinstance(node, BaseModel):
            names = list(type(node).model_fields)
        elif dataclasses.is_dataclass(node) and not isinstance(node, type):
            names = [f.name for f in dataclasses.fields(node)]
        else:
            out[prefix] = plain
            return
        for name in names:
            walk(getattr(node, name), plain[name], f"{prefix}.{name}" if prefix else name)

    walk(config, config_to_dict(config), "")
    return out


def changes_of(recipe: str, base: str = "paper_literal") -> list[Variant]:
    """``recipe``, then ``recipe`` with each setting in which it differs from ``base`` set back
    to ``base``'s value (one at a time, in config order), then ``recipe`` with
    ``experts.learning=false`` if its experts learn. Names: ``RECIPE``, ``RECIPE-without-KEY``,
    ``RECIPE-experts-off``. A setting that only matters under another (``options.*`` with
    ``options.enabled``) is still its own row: put back with the rest of ``recipe`` kept. A
    setting that cannot be put back alone (the config it gives is refused, e.g.
    ``options.source=map`` below the map rung) has no row."""
    from symrl.learner.config import ConfigError, load_config

    mine, theirs = load_config(recipe), load_config(base)
    name = mine.recipe
    ours, other = leaves(mine), leaves(theirs)
    variants = [Variant(name, recipe)]
    for key, value in ours.items():
        if key.startswith(_NOT_CHANGES) or other.get(key) == value:
            continue
        back = other[key]
        try:
            load_config(recipe, [f"{key}={json.dumps(back)}"])
        except ConfigError:
            continue
        shown = (value, back)
        if isinstance(value, dict) and isinstance(back, dict):  # only the entries that differ
            keys = [k for k in {**back, **value} if value.get(k) != back.get(k)]
            shown = ({k: value.get(k) for k in keys}, {k: back.get(k) for k in keys})
        variants.append(
            Variant(
                f"{name}-without-{key}",
                recipe,
                (f"{key}={json.dumps(back)}",),
                f"{key}: {_short(shown[0])} -> {_short(shown[1])}",
            )
        )
    if mine.experts.learning:
        variants.append(
            Variant(
                f"{name}-experts-off",
                recipe,
                ("experts.learning=false",),
                "experts.learning: true -> false",
            )
        )
    return variants


def _short(value: Any) -> str:
    """A setting's value for a table cell (floats to 4 significant digits)."""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_short(v)}" for k, v in value.items()) + "}"
    return str(value)
