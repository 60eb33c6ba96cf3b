"""The mkdocs site: every page in the navigation exists and every API directive names a module
that imports, so `mkdocs build --strict` in CI fails only on real problems."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PUBLIC = {"symrl", "symrl.world", "symrl.knowledge", "symrl.learner", "symrl.train"}

pytestmark = pytest.mark.skipif(
    not (ROOT / "mkdocs.yml").is_file(), reason="needs the source checkout's mkdocs.yml"
)


def _nav_pages(nav) -> list[str]:
    pages = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        pages += _nav_pages(value) if isinstance(value, list) else [value]
    return pages


def _directives() -> dict[str, str]:
    found = {}
    for page in sorted((DOCS / "api").glob("*.md")):
        for name in re.findall(r"^::: ([\w.]+)\s*$", page.read_text(), flags=re.M):
            found[name] = page.name
    return found


def test_every_page_in_the_navigation_exists():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert config["docs_dir"] == "docs"
    pages = _nav_pages(config["nav"])
    assert {"index.md", "ARCHITECTURE.md", "LEARNING.md"} <= set(pages)
    for page in pages:
        assert (DOCS / page).is_file(), page
    in_api = {f"api/{p.name}" for p in (DOCS / "api").glob("*.md")}
    assert in_api <= set(pages), f"API pages missing from the nav: {in_api - set(pages)}"


def test_api_pages_cover_the_public_packages_and_import():
    directives = _directives()
    assert set(directives) >= PUBLIC
    for name in directives:
        importlib.import_module(name)


def test_api_pages_stay_generic():
    """Module-level directives only: pages that name classes would break when a module's
    contents change."""
    for name, page in _directives().items():
        module = importlib.import_module(name)
        assert module.__name__ == name, (page, name)


def test_docstrings_parsed_as_google_without_style_warnings():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    handler = next(p for p in config["plugins"] if isinstance(p, dict) and "mkdocstrings" in p)
    options = handler["mkdocstrings"]["handlers"]["python"]["options"]
    assert options["docstring_style"] == "google"
    assert options["docstring_options"]["warnings"] is False
    assert options["show_submodules"] is True
