"""The import layers of pyproject.toml's ``[tool.importlinter]`` hold, and cover every module."""

from __future__ import annotations

from pathlib import Path

from importlinter.cli import lint_imports

import symrl

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: import-linter's own dependency
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def _contracts() -> list[dict]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]


def test_the_import_contracts_are_kept(monkeypatch):
    """No module imports from a layer above its own (world < knowledge < learner < train <
    runs < studies < cli), in a function or not, and no package's modules import in a circle."""
    monkeypatch.chdir(ROOT)
    assert lint_imports(no_cache=True, no_logo=True) == 0


def test_every_module_of_the_package_has_a_layer():
    """A new top-level module is placed in a layer, or the contract would not look at it."""
    (layers,) = [c["layers"] for c in _contracts() if c["type"] == "layers"]
    layered = {name.strip() for layer in layers for name in layer.split("|")}
    package = Path(symrl.__file__).parent
    modules = {f"symrl.{p.stem}" for p in package.glob("*.py") if p.stem != "__init__"}
    modules |= {f"symrl.{p.parent.name}" for p in package.glob("*/__init__.py")}
    assert modules == layered


def test_the_knowledge_never_imports_the_learner_or_above():
    """The layers' order as written: the agent's knowledge sits below the learner, the
    studies above everything the agent is built from."""
    (layers,) = [c["layers"] for c in _contracts() if c["type"] == "layers"]
    order = [name.strip() for layer in layers for name in layer.split("|")]
    ranks = [
        order.index(f"symrl.{name}")
        for name in ("cli", "studies", "runs", "train", "learner", "knowledge", "world")
    ]
    assert ranks == sorted(ranks)
