"""mkdocs hook: the architecture page's module tree, generated from the package at build time.

The page holds the marker ``<!-- generated: modules -->``; the build replaces it with one row per
module of the packages pyproject.toml ships (``symrl`` and its subpackages, ``symrl.recipes``
included) and the opening sentence of its docstring, read from the source without importing it,
so a module added, moved or removed shows up on the next build.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: import-linter's own dependency
    import tomli as tomllib  # type: ignore[no-redef]

MARKER = "<!-- generated: modules -->"
ROOT = Path(__file__).resolve().parents[2]
SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z`(:])")
ROLE = re.compile(r":[a-z]+:`")


def _summary(path: Path) -> str:
    """The first sentence of the module's docstring (``""`` without one), reST roles dropped."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    paragraph = " ".join(doc.split("\n\n", 1)[0].split())
    return ROLE.sub("`", SENTENCE_END.split(paragraph, maxsplit=1)[0])


def _packages() -> dict[str, Path]:
    """The distribution's packages and their folders, as pyproject.toml ships them."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    moved = setuptools.get("package-dir", {})
    return {name: ROOT / moved.get(name, name.replace(".", "/")) for name in setuptools["packages"]}


def module_rows() -> list[tuple[str, str, str]]:
    """Every module of the package as (dotted name, file in the repository, summary): each
    package, then its modules, packages in the order of their names."""
    rows = []
    for package, folder in sorted(_packages().items()):
        files = sorted(folder.glob("*.py"), key=lambda p: (p.name != "__init__.py", p.name))
        for path in files:
            name = package if path.stem == "__init__" else f"{package}.{path.stem}"
            rows.append((name, path.relative_to(ROOT).as_posix(), _summary(path)))
    return rows


def modules_markdown() -> str:
    """The module tree as a table: each file and what it is."""
    out = ["| file | what it is |", "| --- | --- |"]
    for _name, file, summary in module_rows():
        out.append(f"| `{file}` | {summary.replace('|', chr(92) + '|')} |")
    return "\n".join(out) + "\n"


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    """Replace the module-tree marker of a page with the tree."""
    if MARKER in markdown:
        markdown = markdown.replace(MARKER, modules_markdown())
    return markdown
