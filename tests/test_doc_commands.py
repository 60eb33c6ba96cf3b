"""Every ``symrl ...`` command in the README and the docs parses, and every ``key=value`` in it
names a real config key, so a reader who copies a command gets a run, not a usage error.

Commands are read from fenced code blocks (one per line, ``\\`` continuations joined, shell
``&&``/``;``/``|`` split) and from inline code spans in the prose. A full command is parsed by
symrl's own argparse parser, never run. A usage synopsis (``[--trials N]``, ``RECIPE``,
``drive|train``) is checked more loosely: its command and every ``--flag`` it names must exist.
The journal (``docs/journal/``) is history and exempt.
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

pytestmark = pytest.mark.skipif(
    not (ROOT / "README.md").is_file(), reason="needs the source checkout's README and docs"
)


def published_pages() -> list[Path]:
    """README, RESULTS and the docs outside the journal."""
    pages = [ROOT / "README.md", ROOT / "RESULTS.md"]
    for page in sorted(DOCS.rglob("*.md")):
        rel = page.relative_to(DOCS).as_posix()
        if rel.startswith(("journal/", "hooks/")):
            continue
        pages.append(page)
    return [p for p in pages if p.is_file()]


@dataclass(frozen=True)
class Command:
    where: str
    """file:line, for the failure message."""
    words: tuple[str, ...]
    """The words after ``symrl``."""


FENCE = re.compile(r"^```.*?$(.*?)^```", flags=re.M | re.S)
INLINE = re.compile(r"`((?:python3? -m )?symrl [^`]+)`")
START = re.compile(r"^(?:python3? -m )?symrl$")
IN_LINE = re.compile(r"(?:^|[\s;&|])symrl(?:\s|$)")
SHELL_OPS = {"&&", "||", ";", "|", "&"}
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9_]*(?:,[A-Z0-9_]+)*$")
OVERRIDE = re.compile(r"^[A-Za-z_][\w.]*=")


def _symrl_words(tokens: list[str]) -> list[tuple[str, ...]]:
    """The ``symrl`` commands in a token list split at shell operators."""
    found, segment = [], []
    for token in [*tokens, ";"]:
        if token not in SHELL_OPS:
            segment.append(token)
            continue
        for i in range(len(segment)):
            head = " ".join(
                segment[i : i + 3] if segment[i].startswith("python") else segment[i : i + 1]
            )
            if START.match(head):
                found.append(tuple(segment[i + (3 if head.startswith("python") else 1) :]))
                break
            if not re.match(r"^[A-Z_][A-Z0-9_]*=", segment[i]):  # env assignments come first
                break
        segment = []
    return found


def _line_no(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def commands_in(page: Path, root: Path = ROOT) -> list[Command]:
    """Every symrl command of a Markdown page (named relative to ``root`` in messages)."""
    text = page.read_text()
    name = page.relative_to(root).as_posix()
    found: list[Command] = []
    for block in FENCE.finditer(text):
        lines = block.group(1).replace("\\\n", " ").splitlines()
        first = _line_no(text, block.start(1))
        for k, line in enumerate(lines):
            line = line.strip().removeprefix("$ ")
            if not IN_LINE.search(line) or line.startswith("#"):
                continue
            try:
                lexer = shlex.shlex(line, posix=True, punctuation_chars=";&|")
                lexer.whitespace_split = True
                tokens = list(lexer)
            except ValueError as err:  # an unbalanced quote
                raise AssertionError(f"{name}:{first + k}: {line!r}: {err}") from None
            for words in _symrl_words(tokens):
                found.append(Command(f"{name}:{first + k}", words))
    prose = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for span in INLINE.finditer(prose):
        code = " ".join(span.group(1).replace("\\|", "|").split())
        words = shlex.split(code, comments=False)
        skip = 3 if words[0].startswith("python") else 1
        found.append(Command(f"{name}:{_line_no(prose, span.start())}", tuple(words[skip:])))
    return found


def is_synopsis(words: tuple[str, ...]) -> bool:
    """A usage line rather than a command: brackets, alternatives, placeholders, ellipses."""
    for word in words:
        if OVERRIDE.match(word):
            key, _, value = word.partition("=")
            if value in ("value", "VALUE", "...") or key == "key":
                return True
            continue
        if any(c in word for c in "[]{}<>|()…") or "..." in word or PLACEHOLDER.match(word):
            return True
        if word.startswith("--") and "=" in word and PLACEHOLDER.match(word.split("=", 1)[1]):
            return True
    return False


@cache
def _subparsers():
    import argparse

    from symrl.cli import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, action.choices


@cache
def _defaults() -> dict:
    from symrl.learner.config import RunConfig, config_to_dict

    return config_to_dict(RunConfig())


def unknown_key(override: str) -> str | None:
    """The part of an override's dotted key that names no config key, or None."""
    key = override.split("=", 1)[0]
    node: object = _defaults()
    for i, part in enumerate(key.split(".")):
        if not isinstance(node, dict) or part not in node:
            return ".".join(key.split(".")[: i + 1])
        node = node[part]
    return None


def unknown_names(args) -> list[str]:
    """Recipes and maps a parsed command names that are neither shipped nor a YAML file."""
    from symrl.learner.config import builtin_recipes
    from symrl.world.worldmap import SUITES, builtin_maps, suite_maps

    def files_or(names: str | None, known: list[str], what: str) -> list[str]:
        return [
            f"unknown {what} {name!r}"
            for name in (names or "").split(",")
            if name and name not in known and not name.endswith((".yaml", ".yml"))
        ]

    problems = []
    for attr in ("recipe", "recipes", "changes_of", "base"):
        if isinstance(getattr(args, attr, None), str) and args.command != "baseline":
            problems += files_or(getattr(args, attr), builtin_recipes(), "recipe")
    maps = builtin_maps() + [name for suite in SUITES for name in suite_maps(suite)]
    for attr in ("map", "maps"):
        problems += files_or(getattr(args, attr, None), maps, "map")
    return problems


def check_synopsis(command: Command) -> list[str]:
    _, commands = _subparsers()
    first = command.words[0] if command.words else ""
    names = [n for n in first.split("|") if n] if "|" in first else [first]
    problems = []
    for name in names:
        if name in ("COMMAND", "CMD"):
            continue
        if name not in commands:
            problems.append(f"unknown command {name!r}")
            continue
        flags = {s for a in commands[name]._actions for s in a.option_strings}
        for word in command.words[1:]:
            flag = word.strip("[]{}()").split("=", 1)[0]
            if flag.startswith("--") and flag not in flags:
                problems.append(f"symrl {name} has no option {flag}")
    return problems


def check_command(command: Command) -> list[str]:
    """Parse a full command as `symrl.cli.main` does, without running it."""
    parser, commands = _subparsers()
    words = list(command.words)
    if len(words) == 1 and not words[0].startswith("-"):  # named in the prose: `symrl plan`
        return [] if words[0] in commands else [f"unknown command {words[0]!r}"]
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            args, extra = parser.parse_known_args(words)
    except SystemExit as exit_:
        if exit_.code == 0:  # --help
            return []
        return [f"does not parse: {err.getvalue().strip().splitlines()[-1]}"]
    problems = []
    overrides = list(getattr(args, "overrides", None) or [])
    for word in extra:
        if hasattr(args, "overrides") and "=" in word and not word.startswith("-"):
            overrides.append(word)
        else:
            problems.append(f"unrecognized argument {word!r}")
    problems += unknown_names(args)
    for override in overrides:
        if "=" not in override:
            problems.append(f"{override!r} is not key=value")
            continue
        bad = unknown_key(override)
        if bad is not None:
            problems.append(f"{override!r}: {bad!r} is not a config key")
    return problems


def all_commands() -> list[Command]:
    return [c for page in published_pages() for c in commands_in(page)]


def test_the_extractor_finds_commands_in_blocks_spans_and_chains(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "Run `symrl plan --map office` or `python -m symrl train paper\n--trials 2`.\n\n"
        "```bash\n"
        "pip install -e . && symrl study paper_map --sets 2 update.gamma=0.9  # a comment\n"
        "PYTHONHASHSEED=0 symrl ablate \\\n  --recipes paper_map,reflex_only\n"
        "# symrl train commented-out\n"
        "```\n"
    )
    got = [c.words for c in commands_in(page, tmp_path)]
    assert got == [
        ("study", "paper_map", "--sets", "2", "update.gamma=0.9"),
        ("ablate", "--recipes", "paper_map,reflex_only"),
        ("plan", "--map", "office"),
        ("train", "paper", "--trials", "2"),
    ]


def test_the_checker_catches_bad_commands_and_keys():
    assert check_command(Command("t", ("train", "paper", "update.gamma=0.9"))) == []
    assert (
        check_command(Command("t", ("study", "paper", "--sets", "2", "reflex.near.FL=[0.1,0.4]")))
        == []
    )
    assert check_command(Command("t", ("train", "paper", "options.prior=0.5"))) == [
        "'options.prior=0.5': 'options.prior' is not a config key"
    ]
    assert check_command(Command("t", ("study", "paper", "aim.rate=1"))) == [
        "'aim.rate=1': 'aim' is not a config key"
    ]
    problems = check_command(Command("t", ("train", "paper", "--trails", "2")))
    assert "unrecognized argument '--trails'" in problems
    assert check_command(Command("t", ("study", "paper_mapp"))) == ["unknown recipe 'paper_mapp'"]
    assert check_command(Command("t", ("plan", "--map", "ofice"))) == ["unknown map 'ofice'"]
    assert check_command(Command("t", ("plan", "--map", "my_world.yaml"))) == []
    assert check_command(Command("t", ("plan", "--map", "tuning/long_wall"))) == []
    assert "unrecognized argument '--sets'" in check_command(Command("t", ("plan", "--sets", "2")))
    assert check_command(Command("t", ("fly",))) == ["unknown command 'fly'"]
    assert is_synopsis(("train", "RECIPE", "[--trials", "N]"))
    assert not is_synopsis(("sweep", "--recipes", "a", "'reflex.peaks=[1,0,-1]'".strip("'")))
    assert check_synopsis(Command("t", ("train", "RECIPE", "[--trails", "N]"))) == [
        "symrl train has no option --trails"
    ]
    assert check_synopsis(Command("t", ("drive|plan", "--map", "M"))) == []


def test_the_published_pages_hold_many_commands():
    commands = all_commands()
    full = [c for c in commands if not is_synopsis(c.words)]
    assert len(full) >= 40, len(full)
    assert {"README.md", "RESULTS.md"} <= {c.where.split(":")[0] for c in commands}


def test_every_published_command_parses_and_names_real_keys():
    problems = []
    for command in all_commands():
        check = check_synopsis if is_synopsis(command.words) else check_command
        problems += [
            f"{command.where}: symrl {' '.join(command.words)}: {p}" for p in check(command)
        ]
    assert not problems, "\n".join(problems)
