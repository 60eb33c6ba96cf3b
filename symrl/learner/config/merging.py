"""Merging a run's layers: the ``key=value`` overrides parsed, the layers (recipe, overrides)
merged over the mapping fields' defaults by OmegaConf, a clash or a bad interpolation one line."""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING, Any, cast

import yaml
from pydantic import BaseModel

from symrl.learner.config.schema import ConfigError, RunConfig, config_to_dict, plain

if TYPE_CHECKING:  # OmegaConf is imported where a recipe or an override is read (~40 ms)
    from omegaconf import DictConfig


def parse_overrides(overrides: list[str] | tuple[str, ...]) -> list[tuple[str, str, DictConfig]]:
    """Each ``key=value`` as (text, dotted key, nested config); the value is read as YAML. A key
    given twice (or inside another given key) and the recipe's name are refused."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    out: list[tuple[str, str, DictConfig]] = []
    for text in overrides:
        if "=" not in text:
            raise ConfigError(f"override {text!r}: expected key=value, e.g. update.gamma=0.9")
        key, value = text.split("=", 1)
        key = key.strip()
        if not all(key.split(".")):
            raise ConfigError(f"override {text!r}: empty key")
        if key == "recipe":
            raise ConfigError(
                f"{text}: the recipe's name is not a key to override; name the recipe or its file"
            )
        for other, known, _ in out:
            if key == known or key.startswith(known + ".") or known.startswith(key + "."):
                raise ConfigError(f"{text}: {key} is already set by {other}; give each key once")
        try:
            out.append((text, key, OmegaConf.from_dotlist([f"{key}={value}"])))
        except yaml.YAMLError as err:
            problem = " ".join((getattr(err, "problem", None) or str(err)).split())
            raise ConfigError(f"{text}: not a valid YAML value ({problem})") from None
        except OmegaConfBaseException as err:  # e.g. a malformed ${...}
            raise ConfigError(f"{text}: {first_line(err)}") from None
    return out


ABSENT = object()


@functools.cache
def _mapping_fields() -> dict[str, dict[str, Any]]:
    """Every mapping field (``reflex.near``, ``reflex.sectors``) by dotted key, with its default
    entries: pydantic fills in a missing field but not a mapping's missing entries."""

    def walk(prefix: str, section: Any) -> dict[str, dict[str, Any]]:
        names = (
            [f.name for f in dataclasses.fields(section)]
            if dataclasses.is_dataclass(section)
            else list(type(section).model_fields)
        )
        out: dict[str, dict[str, Any]] = {}
        for name in names:
            value = getattr(section, name)
            if isinstance(value, BaseModel) or dataclasses.is_dataclass(value):
                out |= walk(f"{prefix}{name}.", value)
            elif isinstance(value, dict):
                out[f"{prefix}{name}"] = plain(value)
        return out

    return walk("", RunConfig())


@functools.cache
def _mapping_defaults() -> DictConfig:
    """What the layers are merged over: the mapping fields' default entries (the rest of the
    defaults pydantic fills in; giving them to OmegaConf would only cost its time)."""
    from omegaconf import OmegaConf

    base = OmegaConf.create()
    for key, entries in _mapping_fields().items():
        OmegaConf.update(base, key, entries)
    return base


def is_complete(data: dict[str, Any]) -> bool:
    """Whether merging ``data`` over the defaults changes nothing pydantic would not fill in:
    each mapping field it gives has every default entry (a checkpoint's config does), and no
    string of it is an interpolation."""
    for key, entries in _mapping_fields().items():
        given = value_at(data, key, ABSENT)
        if given is not ABSENT and not (isinstance(given, dict) and entries.keys() <= given.keys()):
            return False
    return "${" not in repr(data)


def merge_layers(layers: list[tuple[str, Any]]) -> dict[str, Any]:
    """``layers`` (source, data) merged in order: mappings merge entry by entry, anything else
    replaces (``reflex.near.FL=[0.1, 0.3]`` keeps the other sectors); ``${key}`` interpolations
    are resolved. Keys no layer names take their defaults when pydantic validates."""
    from omegaconf import OmegaConf
    from omegaconf.errors import (
        InterpolationKeyError,
        InterpolationResolutionError,
        OmegaConfBaseException,
    )

    datas = [data for _, data in layers]
    try:
        merged = OmegaConf.merge(_mapping_defaults(), *datas)
        try:
            out = OmegaConf.to_container(merged, resolve=True)
        except InterpolationKeyError:  # it may name a key no layer sets: over every default
            every = OmegaConf.create(config_to_dict(RunConfig()))
            merged = OmegaConf.merge(_mapping_defaults(), every, *datas)
            out = OmegaConf.to_container(merged, resolve=True)
    except InterpolationResolutionError as err:
        key = str(getattr(err, "full_key", "") or "")
        value = value_at(OmegaConf.to_container(merged), key)
        raise ConfigError(f"{key or 'config'}={value!r}: {first_line(err)}") from None
    except (OmegaConfBaseException, TypeError, ValueError):
        below: Any = OmegaConf.to_container(_mapping_defaults())
        for source, data in layers:  # which layer puts a list over a mapping or the reverse
            clash = _clash(below, container(data))
            if clash is not None:
                key, value = clash
                shown = f"{source}: " if source.startswith("recipe ") else ""
                raise ConfigError(
                    f"{shown}{key}={value!r}: a mapping and a list cannot replace each other"
                ) from None
            below = OmegaConf.to_container(OmegaConf.merge(below, data))
        raise
    return cast("dict[str, Any]", out)


def first_line(err: Exception) -> str:
    """OmegaConf's message without the lines of context it adds (``full_key: ...``)."""
    return " ".join(str(err).splitlines()[0].split()) if str(err) else type(err).__name__


def container(data: Any) -> Any:
    from omegaconf import DictConfig, ListConfig, OmegaConf

    return OmegaConf.to_container(data) if isinstance(data, (DictConfig, ListConfig)) else data


def _clash(base: Any, data: Any, prefix: str = "") -> tuple[str, Any] | None:
    """The first key where ``data`` puts a mapping over a list or a list over a mapping."""
    if not isinstance(base, dict) or not isinstance(data, dict):
        return None
    for name, value in data.items():
        key, old = f"{prefix}{name}", base.get(name)
        if (
            isinstance(old, dict)
            and isinstance(value, list)
            or (isinstance(old, list) and isinstance(value, dict))
        ):
            return key, value
        found = _clash(old, value, key + ".")
        if found is not None:
            return found
    return None


def value_at(data: Any, key: str, default: Any = None) -> Any:
    """The value at dotted ``key`` in nested mappings (``default`` where there is none)."""
    for part in key.split(".") if key else []:
        if not isinstance(data, dict) or part not in data:
            return default
        data = data[part]
    return data
