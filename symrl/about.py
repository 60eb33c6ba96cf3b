"""About the installed symrl: its version and :func:`provenance` (which code and libraries ran).

Everything here is read from installed package metadata, never from a version-control tool, so
the answer describes the installed ``symrl`` whichever folder the caller runs in.

The code revision comes from the local part of symrl's version, which setuptools-scm writes when
the package is built or installed: ``0.1.dev12+g1a2b3c4`` is commit ``1a2b3c4``, and a ``.d<date>``
segment (``+g1a2b3c4.d20260102``) means the tree had uncommitted changes. A release built from a
clean tag (``0.2.0``) has no local part: the version alone names the code. An editable install
(``pip install -e .``) keeps the revision of the moment it was installed; ``editable`` says so.
"""

from __future__ import annotations

import json
import platform
import re
from importlib import metadata
from typing import Any

__all__ = ["__version__", "provenance", "package_version", "parse_revision"]

LIBRARIES = ("torch", "torchrl", "tensordict", "gymnasium", "numpy")
"""The libraries whose versions :func:`provenance` reports, beside symrl's and Python's."""

_NODE = re.compile(r"^g([0-9a-f]{4,40})$")
_DATE = re.compile(r"^d\d{8}$")


def package_version(name: str) -> str | None:
    """The installed version of distribution ``name``, or None if it is not installed."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


__version__: str = package_version("symrl") or "0+unknown"
"""symrl's version: the installed distribution's metadata, the one place it is recorded."""


def parse_revision(version: str | None) -> tuple[str | None, bool | None]:
    """``(commit, dirty)`` from a setuptools-scm version string.

    ``"0.1.dev3+g1a2b3c4"`` -> ``("1a2b3c4", False)``; ``"0.1.dev3+g1a2b3c4.d20260102"`` ->
    ``("1a2b3c4", True)``; ``"0.2.0+d20260102"`` -> ``(None, True)``; ``"0.2.0"`` ->
    ``(None, False)``; ``None`` -> ``(None, None)``.
    """
    if version is None:
        return None, None
    _, plus, local = version.partition("+")
    if not plus:
        return None, False
    commit, dirty = None, False
    for part in local.split("."):
        node = _NODE.match(part)
        if node:
            commit = node.group(1)
        elif _DATE.match(part):
            dirty = True
    return commit, dirty


def _editable(name: str) -> bool | None:
    """True for an editable install (PEP 660 ``direct_url.json``), None if unknown."""
    try:
        text = metadata.distribution(name).read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    if not text:
        return False
    try:
        return bool(json.loads(text).get("dir_info", {}).get("editable", False))
    except (ValueError, AttributeError):
        return None


def provenance() -> dict[str, Any]:
    """Versions of symrl, its main libraries and Python, and the code revision of symrl.

    Returns a dict with the keys ``symrl``, ``torch``, ``torchrl``, ``tensordict``,
    ``gymnasium``, ``numpy`` (version strings, None where a library is not installed),
    ``python`` (e.g. ``"3.11.7"``), ``revision`` (the short commit hash symrl was built from, or
    None when the version does not carry one), ``dirty`` (True if it was built from a tree with
    uncommitted changes, None if unknown) and ``editable`` (True for an editable install, whose
    revision is that of its install time).
    """
    version = package_version("symrl")
    revision, dirty = parse_revision(version)
    info: dict[str, Any] = {"symrl": version}
    info.update({name: package_version(name) for name in LIBRARIES})
    info["python"] = platform.python_version()
    info["revision"] = revision
    info["dirty"] = dirty
    info["editable"] = _editable("symrl")
    return info
