"""The mkdocs site: every page in the navigation exists and every API directive names a module
that imports, so `mkdocs build --strict` in CI fails only on real problems."""

from __future__ import annotations

import importlib
import json
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


def _config() -> dict:
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text())


def test_every_page_in_the_navigation_exists():
    config = _config()
    assert config["docs_dir"] == "docs"
    pages = _nav_pages(config["nav"])
    assert {
        "index.md",
        "explanation/architecture.md",
        "explanation/algorithm.md",
        "explanation/baselines.md",
        "reference/map-format.md",
    } <= set(pages)
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


JOURNAL = sorted((DOCS / "journal").glob("*.md"))
"""The lab notebook: history, kept out of the navigation."""


def test_the_docs_top_level_holds_only_the_home_page():
    """Every other page lives in its purpose's folder (tutorials, how-to, reference, explanation)
    or in the journal."""
    pages = sorted(p.name for p in DOCS.iterdir() if p.is_file())
    assert pages == ["index.md"]
    folders = {p.name for p in DOCS.iterdir() if p.is_dir()}
    assert {"tutorials", "how-to", "reference", "explanation", "journal"} <= folders


def test_the_navigation_is_sorted_by_purpose():
    sections = [next(iter(item)) for item in _config()["nav"]]
    assert sections == ["Home", "Tutorials", "How-to guides", "Reference", "Explanation"]


def test_the_journal_is_outside_the_navigation_and_marked_as_history():
    config = _config()
    pages = set(_nav_pages(config["nav"]))
    hidden = config["not_in_nav"].split()
    assert hidden == ["/journal/"]
    assert len(JOURNAL) >= 4
    for page in JOURNAL:
        name = page.relative_to(DOCS).as_posix()
        assert name not in pages, name
        opening = page.read_text()[:600]
        assert "history, not documentation" in opening.lower(), name


def test_user_pages_do_not_read_as_a_work_log():
    """Pages in the navigation explain the current code; how it was reached is the journal's."""
    log = re.compile(
        r"throw-away patch|a checkout before|compare a checkout|this session|the last session"
        r"|issue \d+|#\d{2,}",
        flags=re.I,
    )
    for page in _nav_pages(_config()["nav"]):
        text = (DOCS / page).read_text()
        assert not log.search(text), (page, log.search(text))


def _hook(name: str = "reference"):
    """An mkdocs hook of docs/hooks/: ``reference`` generates the reference tables, ``modules``
    the architecture page's module tree."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"docs_{name}", DOCS / "hooks" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _paths(data: dict, prefix: str = "") -> list[str]:
    out = []
    for key, value in data.items():
        path = f"{prefix}{key}"
        out += _paths(value, path + ".") if isinstance(value, dict) and value else [path]
    return out


def test_the_config_reference_lists_every_key_with_its_default():
    from symrl.learner.config import RunConfig, config_to_dict

    defaults = config_to_dict(RunConfig())
    rows = {
        key: (default, doc) for _, section in _hook().config_rows() for key, default, doc in section
    }
    for path in _paths(defaults):  # every key is a row, or inside a mapping-valued row
        assert any(path == key or path.startswith(key + ".") for key in rows), path
    for key, (default, _doc) in rows.items():
        value = defaults
        for part in key.split("."):
            value = value[part]
        assert default == json.dumps(value), key
    assert rows["update.gamma"] == ("0.95", rows["update.gamma"][1])
    assert "discount" in rows["update.gamma"][1].lower()
    assert rows["knowledge"][0] == '"regions"'
    markdown = _hook().config_markdown()
    assert "| `options.enabled` | `false` |" in markdown


def test_the_cli_reference_has_every_command_and_the_recipes_table_every_recipe():
    from symrl.learner.config import builtin_recipes

    hook = _hook()
    cli = hook.cli_markdown()
    for command in (
        "drive",
        "train",
        "evaluate",
        "study",
        "ablate",
        "plan",
        "baseline",
        "generalise",
        "sweep",
    ):
        assert f"## `symrl {command}`" in cli
    assert "--help-keys" in cli
    recipes = hook.recipes_markdown()
    for name in builtin_recipes():
        assert f"| `{name}` |" in recipes
    assert "| `paper_map` | `map` |" in recipes


def test_the_hook_replaces_its_markers():
    hook = _hook()
    page = "before\n<!-- generated: recipes -->\nafter"
    out = hook.on_page_markdown(page, page=None, config=None, files=None)
    assert "<!-- generated" not in out and "| `paper_literal` |" in out
    for name in hook.GENERATORS:
        assert any(
            hook.MARKER.format(name) in p.read_text() for p in (DOCS / "reference").glob("*.md")
        ), name


def test_the_readme_is_an_overview_with_the_command_ci_runs():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 150
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci == "pytest -n 2 tests && pytest --nbmake notebooks"
    assert f'pip install -e ".[dev]" && {ci}\n' in readme
    assert "## What each piece of knowledge buys" in readme
    for recipe in ("reflex_only", "paper_literal", "paper", "paper_map"):
        assert f"`{recipe}`" in readme


def test_the_module_tree_lists_every_module_of_the_package():
    import importlib.util
    import pkgutil

    import symrl

    rows = _hook("modules").module_rows()
    names = [name for name, _file, _summary in rows]
    assert len(names) == len(set(names))
    found = {m.name for m in pkgutil.walk_packages(symrl.__path__, "symrl.")}
    assert found | {"symrl", "symrl.recipes"} <= set(names), found - set(names)
    for name, file, summary in rows:
        spec = importlib.util.find_spec(name)
        assert spec is not None and spec.origin is not None, name
        assert Path(spec.origin).resolve() == (ROOT / file).resolve(), (name, file)
        assert summary, f"{file} has no docstring"
    for module in (
        "symrl.collector",
        "symrl.learner.perception",
        "symrl.learner.progress",
        "symrl.learner.option_critic",
        "symrl.studies.sweep",
    ):
        assert module in names


def test_the_module_tree_follows_the_code(tmp_path, monkeypatch):
    """A module added to a package is a row on the next build, with its docstring's first
    sentence; a package moved by ``package-dir`` is read from its folder."""
    (tmp_path / "pyproject.toml").write_text(
        '[tool.setuptools]\npackages = ["pkg", "pkg.data"]\npackage-dir = { "pkg.data" = "data" }\n'
    )
    (tmp_path / "pkg").mkdir()
    (tmp_path / "data").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text('"""The package."""\n')
    (tmp_path / "pkg" / "new.py").write_text('"""A new module. More about it.\n\nDetails."""\n')
    (tmp_path / "data" / "__init__.py").write_text("")
    hook = _hook("modules")
    monkeypatch.setattr(hook, "ROOT", tmp_path)
    assert hook.module_rows() == [
        ("pkg", "pkg/__init__.py", "The package."),
        ("pkg.new", "pkg/new.py", "A new module."),
        ("pkg.data", "data/__init__.py", ""),
    ]


def test_the_architecture_page_has_the_generated_tree_and_no_hand_written_one():
    assert "docs/hooks/modules.py" in _config()["hooks"]
    page = (DOCS / "explanation" / "architecture.md").read_text()
    hook = _hook("modules")
    assert hook.MARKER in page
    assert "\nsymrl/\n" not in page and "  cli.py " not in page
    built = hook.on_page_markdown(page, page=None, config=None, files=None)
    assert hook.MARKER not in built
    assert "| `symrl/learner/perception.py` | What the robot makes of an observation" in built
