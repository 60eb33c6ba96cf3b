"""The recipes: the built-in ones (the package ``symrl.recipes``) and a recipe file read as one
mapping by OmegaConf, every fault of the file one line naming it."""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from symrl.learner.config.merging import first_line
from symrl.learner.config.schema import ConfigError

if TYPE_CHECKING:  # OmegaConf is imported where a recipe or an override is read (~40 ms)
    from omegaconf import DictConfig


def builtin_recipes() -> list[str]:
    """Names of the recipes shipped in the top-level ``recipes/`` (the package
    ``symrl.recipes``)."""
    folder = resources.files("symrl.recipes")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def recipe_path(recipe: str | Path) -> tuple[str, Path]:
    text = str(recipe)
    if text.endswith((".yaml", ".yml")) or "/" in text or Path(text).is_file():
        path = Path(text)
        if not path.is_file():
            raise ConfigError(f"recipe {text!r}: no such file")
        return path.stem, path
    path = Path(str(resources.files("symrl.recipes") / f"{text}.yaml"))
    if not path.is_file():
        raise ConfigError(
            f"recipe {text!r}: unknown; built-in recipes are {', '.join(builtin_recipes())} "
            "(or pass a YAML file path)"
        )
    return text, path


def read_recipe(text: str, path: Path) -> DictConfig:
    """The recipe file as a mapping (OmegaConf's YAML loader refuses a key given twice)."""
    stat = path.stat()
    return _read_recipe_file(text, str(path.resolve()), stat.st_mtime_ns, stat.st_size)


MAX_RECIPE_BYTES = 256 * 1024
"""Largest recipe file read (the built-in ones are 1-5 KiB)."""


@functools.lru_cache(maxsize=64)
def _read_recipe_file(text: str, path: str, mtime_ns: int, size: int) -> DictConfig:
    """Kept while the file is unchanged: studies and tests load the same recipes many times,
    and merging never changes its inputs."""
    from omegaconf import DictConfig, ListConfig, OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    if size > MAX_RECIPE_BYTES:  # before reading it: a recipe sets a few dozen keys
        raise ConfigError(
            f"recipe {text!r}: {size / 2**20:.1f} MiB, far larger than a recipe (at most "
            f"{MAX_RECIPE_BYTES // 1024} KiB: a recipe sets a few dozen keys); is it the right "
            "file?"
        )
    try:
        data = OmegaConf.load(path)
    except yaml.MarkedYAMLError as err:
        where = f"line {err.problem_mark.line + 1}: " if err.problem_mark else ""
        problem = " ".join(str(err.problem or err).split())
        if "node expansion exceeds" in problem:  # OmegaConf's cap on nodes, aliases or not
            raise ConfigError(
                f"recipe {text!r}: too many entries (over 10,000 YAML nodes); a recipe sets a "
                "few dozen keys"
            ) from None
        raise ConfigError(f"recipe {text!r}: not valid YAML ({where}{problem})") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        problem = " ".join(str(err).split())
        raise ConfigError(f"recipe {text!r}: not valid YAML ({problem})") from None
    except OmegaConfBaseException as err:  # e.g. a malformed ${...}
        key = getattr(err, "full_key", None) or "config"
        raise ConfigError(f"recipe {text!r}: {key}: {first_line(err)}") from None
    if not isinstance(data, DictConfig) or not data:
        shown = OmegaConf.to_container(data) if isinstance(data, ListConfig) else data
        raise ConfigError(f"recipe {text!r}: expected a non-empty mapping, got {shown!r}")
    empty = _empty_mapping(data, "")
    if empty is not None:
        raise ConfigError(
            f"recipe {text!r}: {empty}: an empty mapping changes nothing (mappings merge entry "
            "by entry); set its entries or leave it out"
        )
    return data


def _empty_mapping(data: Any, prefix: str) -> str | None:
    """The dotted key of the first empty mapping in ``data`` (None: there is none)."""
    for key, value in data.items():
        name = f"{prefix}{key}"
        if hasattr(value, "items"):
            if not value:
                return name
            inner = _empty_mapping(value, f"{name}.")
            if inner is not None:
                return inner
    return None
