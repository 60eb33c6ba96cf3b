"""mkdocs hook: the reference pages' tables, generated from the code at build time.

A page holds a marker such as ``<!-- generated: config -->``; the build replaces it with the
table read from the code (the CLI's argparse parser, the config schema, the shipped recipes), so
the reference cannot fall behind the code it describes.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import json
import os
import textwrap
import typing
from typing import Any

MARKER = "<!-- generated: {} -->"


def _field_docs(cls: type) -> dict[str, str]:
    """The attribute docstrings of ``cls`` (the string literal right under each field)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    docs = {}
    for node, after in zip(body, body[1:], strict=False):
        if (
            isinstance(node, ast.AnnAssign)
            and isinstance(node.target, ast.Name)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)
        ):
            docs[node.target.id] = " ".join(inspect.cleandoc(after.value.value).split())
    return docs


def _fields(cls: type) -> list[str]:
    if dataclasses.is_dataclass(cls):
        return [f.name for f in dataclasses.fields(cls)]
    return list(cls.model_fields)  # type: ignore[attr-defined]


def _is_section(hint: Any) -> bool:
    return inspect.isclass(hint) and (
        dataclasses.is_dataclass(hint) or hasattr(hint, "model_fields")
    )


def config_rows() -> list[tuple[str, list[tuple[str, str, str]]]]:
    """Every config key as (section, [(dotted key, default, meaning)]), in the schema's order;
    the section ``""`` holds the top-level keys."""
    from symrl.learner.config import RunConfig, config_to_dict

    sections: list[tuple[str, list[tuple[str, str, str]]]] = []

    def walk(cls: type, prefix: str, defaults: dict[str, Any]) -> None:
        hints = typing.get_type_hints(cls)
        docs = _field_docs(cls)
        rows: list[tuple[str, str, str]] = []
        sections.append((prefix, rows))
        nested = []
        for name in _fields(cls):
            key = f"{prefix}.{name}" if prefix else name
            if _is_section(hints.get(name)):
                nested.append((hints[name], key, defaults[name]))
            else:
                rows.append((key, json.dumps(defaults[name]), docs.get(name, "")))
        for section in nested:
            walk(*section)

    walk(RunConfig, "", config_to_dict(RunConfig()))
    return [(prefix, rows) for prefix, rows in sections if rows]


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def config_markdown() -> str:
    """The config reference: one table per section."""
    out = []
    for prefix, rows in config_rows():
        out += [f"### `{prefix}`" if prefix else "### Top-level keys", ""]
        out += ["| key | default | meaning |", "| --- | --- | --- |"]
        out += [f"| `{key}` | `{_cell(default)}` | {_cell(doc)} |" for key, default, doc in rows]
        out.append("")
    return "\n".join(out)


def cli_markdown() -> str:
    """Every ``symrl`` command's ``--help``, as argparse prints it."""
    from symrl.cli import build_parser

    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal's width
    try:
        parser = build_parser()
        commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        out = ["```text", parser.format_help().rstrip(), "```", ""]
        for name, sub in commands.choices.items():
            out += [f"## `symrl {name}`", "", "```text", sub.format_help().rstrip(), "```", ""]
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return "\n".join(out)


def recipes_markdown() -> str:
    """The shipped recipes: name, knowledge rung and the recipe file's opening comment."""
    from importlib import resources

    from symrl.learner.config import builtin_recipes, load_config

    out = ["| recipe | knowledge | what it is |", "| --- | --- | --- |"]
    for name in builtin_recipes():
        text = (resources.files("symrl.recipes") / f"{name}.yaml").read_text()
        comment = []
        for line in text.splitlines():
            if not line.startswith("#"):
                break
            comment.append(line.lstrip("# ").strip())
        about = " ".join(comment).removeprefix(f"{name}:").strip()
        rung = load_config(name).knowledge
        out.append(f"| `{name}` | `{rung}` | {_cell(about)} |")
    return "\n".join(out) + "\n"


GENERATORS = {"config": config_markdown, "cli": cli_markdown, "recipes": recipes_markdown}


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    """Replace each generated-table marker of a page with its table."""
    for name, make in GENERATORS.items():
        marker = MARKER.format(name)
        if marker in markdown:
            markdown = markdown.replace(marker, make())
    return markdown
