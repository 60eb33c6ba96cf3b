"""Numbers in a config are numbers: the checks pydantic's lax mode and the dataclass sections
(``env.robot``, ``reflex``) do not make, run on the merged config before it is validated.

* no boolean or string where a number belongs (``update.gamma=True`` would run with 1.0,
  ``gamma: "0.9"`` would be read from the string);
* no number beyond :data:`MAX_MAGNITUDE` in a float key (``trial_gradient.rate=1e308`` or
  ``env.robot.sonar_noise_std=1e308`` would overflow the arithmetic), unless the key has a
  tighter bound of its own;
* a fixed-length tuple (``reflex.peaks``) given the right number of entries (pydantic names the
  first missing index instead).

Each fault is ``(dotted key, "key=value: reason")``, one line.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from typing import Any

from pydantic import BaseModel

__all__ = ["MAX_MAGNITUDE", "number_fault"]

MAX_MAGNITUDE = 1e6
"""Largest |value| of a float config key (no key means anything near it; beyond it products of a
few keys overflow float64)."""

_NUMBER = (int, float)


def _plain(annotation: Any) -> tuple[Any, bool]:
    """``annotation`` without ``None`` (``float | None`` -> float) and whether it had one."""
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        rest = [a for a in args if a is not type(None)]
        if len(rest) == 1:
            return rest[0], len(rest) < len(args)
    return annotation, False


@functools.cache
def _fields(section: type) -> dict[str, Any]:
    """Field name -> annotation of a pydantic model or a dataclass."""
    if isinstance(section, type) and issubclass(section, BaseModel):
        return {name: f.annotation for name, f in section.model_fields.items()}
    hints = typing.get_type_hints(section)
    return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(section)}  # type: ignore[arg-type]


def _is_section(annotation: Any) -> bool:
    return isinstance(annotation, type) and (
        issubclass(annotation, BaseModel) or dataclasses.is_dataclass(annotation)
    )


def _what(value: Any) -> str:
    return "a boolean" if isinstance(value, bool) else "a string"


def _non_finite(text: str) -> bool:
    try:
        return not math.isfinite(float(text))
    except ValueError:
        return False


def _number(key: str, value: Any, annotation: Any, shown: Any) -> str | None:
    """The fault of ``value`` for a number field, if any."""
    if isinstance(value, str) and _non_finite(value):
        return f"{key}={shown!r}: expected a finite number"
    if isinstance(value, (bool, str)):
        example = "e.g. 20" if annotation is int else "e.g. 0.9"
        return (
            f"{key}={shown!r}: expected a number, not {_what(value)} (write it unquoted, {example})"
        )
    if (
        annotation is float
        and isinstance(value, _NUMBER)
        and math.isfinite(value)
        and (abs(value) > MAX_MAGNITUDE)
    ):
        return (
            f"{key}={shown!r}: out of range; a number within +-{MAX_MAGNITUDE:g} is "
            "expected (a larger one overflows the arithmetic)"
        )
    if annotation is int and isinstance(value, int) and abs(value) >= 2**63:
        return f"{key}={shown!r}: out of range; an integer below 2**63 is expected"
    return None


def number_fault(section: type, data: Any, prefix: str = "") -> tuple[str, str] | None:
    """The first number fault of ``data`` (a mapping for ``section``) as (dotted key, one-line
    message), or None. Keys ``section`` does not have are left to pydantic."""
    if not isinstance(data, dict):
        return None
    fields = _fields(section)
    for name, value in data.items():
        if name not in fields:
            continue
        key = f"{prefix}{name}"
        annotation, _ = _plain(fields[name])
        if _is_section(annotation):
            found = number_fault(annotation, value, f"{key}.")
            if found is not None:
                return found
            continue
        if annotation in (int, float):
            fault = _number(key, value, annotation, value)
        elif typing.get_origin(annotation) is typing.Annotated:
            base = typing.get_args(annotation)[0]
            fault = _number(key, value, base, value) if base in (int, float) else None
        elif typing.get_origin(annotation) is tuple and isinstance(value, (list, tuple)):
            fault = _tuple(key, value, typing.get_args(annotation))
        else:
            fault = None
        if fault is not None:
            return key, fault
    return None


def _tuple(key: str, value: Any, args: tuple[Any, ...]) -> str | None:
    """A ``tuple[float, float, float]`` or ``tuple[int, ...]`` field's fault."""
    if len(args) == 2 and args[1] is Ellipsis:
        kinds = [args[0]] * len(value)
    else:
        if len(value) != len(args):
            return f"{key}={list(value)!r}: expected {len(args)} numbers, got {len(value)}"
        kinds = list(args)
    for item, kind in zip(value, kinds, strict=True):
        if kind in (int, float):
            fault = _number(key, item, kind, list(value))
            if fault is not None:
                return fault
    return None
