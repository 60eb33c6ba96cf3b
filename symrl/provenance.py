"""Versions of symrl and the libraries a result depends on (recorded in every run)."""

from __future__ import annotations

import platform
from importlib import metadata

__all__ = ["provenance"]


def provenance() -> dict[str, str]:
    """symrl, torch, torchrl, tensordict, gymnasium, numpy and python versions."""
    out = {}
    for name in ("symrl", "torch", "torchrl", "tensordict", "gymnasium", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    out["python"] = platform.python_version()
    return out
