"""Input errors in one line: argparse's usage errors, the faults a command finds before any
work (an output folder it cannot write, a clashing override, an empty path) and the report of
an input error that ends a command (exit 2)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

_YAML11_BOOLS = {"yes", "no", "on", "off"}
"""Words YAML 1.1 reads as booleans; an override spells them true / false."""


def one_line_errors(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Usage errors of ``parser`` as one line (``symrl CMD: error: ...``), exit 2."""

    def error(message: str):
        parser.exit(2, f"{parser.prog}: error: {message}\n")

    parser.error = error  # type: ignore[method-assign]
    return parser


def one_line(err: BaseException) -> str:
    """An input error's message on one line."""
    return " ".join(str(err).split())


def input_error(command: str, err: ValueError | OSError) -> int:
    """Report a configuration or input error (or a file or folder the command cannot read or
    write) as one line, no deep traceback; returns the exit code, 2."""
    if isinstance(err, OSError) and not isinstance(err, (FileNotFoundError, FileExistsError)):
        where = f"{err.filename!r}: " if err.filename else ""
        print(f"symrl {command}: error: {where}{err.strerror or err}", file=sys.stderr)
    else:
        print(f"symrl {command}: error: {one_line(err)}", file=sys.stderr)
    return 2


def output_folder(
    flag: str,
    path: str | Path,
    results: Sequence[str] = (),
    overwrite: bool = False,
    command: str = "",
) -> Path:
    """Check, before any work, that the output folder ``path`` of ``flag`` can be made and
    written, and that it holds none of the ``results`` files of an earlier run of ``command``
    unless ``overwrite`` (or the run was stopped after writing some: ``--resume`` finishes it):
    each fault one line. Nothing is created here."""
    import os

    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"{flag} {str(path)!r}: exists and is not a folder")
    probe = folder
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise ValueError(f"{flag} {str(path)!r}: cannot make it ({str(probe)!r} is a file)")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"{flag} {str(path)!r}: cannot write in {str(probe)!r} (read-only)")
    from symrl.studies.checkpointing import STOPPED_NAME

    held = [name for name in results if (folder / name).exists()]
    if held and not overwrite and not (folder / STOPPED_NAME).is_file():  # a stopped one: resume
        raise ValueError(
            f"{flag} {str(path)!r}: holds the results of an earlier `symrl {command}` "
            f"({', '.join(held)}); pass --overwrite to replace them, or another {flag}"
        )
    return folder


def recipe_argument(recipe: str | None) -> None:
    """A folder given as RECIPE is a one-line error (the loader would say 'no such file')."""
    if recipe is not None and Path(recipe).is_dir():
        raise ValueError(
            f"recipe {recipe!r}: is a folder; give a recipe name (e.g. paper) or a YAML file"
        )


def check_overrides(overrides: Sequence[str], taken: dict[str, str]) -> None:
    """Refuse, in one line, the ``key=value`` overrides that would be silently dropped or
    silently win: a key given twice, ``recipe=`` (the RECIPE argument names the recipe), a key
    a flag of the command sets (``taken``: key -> the flag), an empty mapping (mappings merge
    entry by entry, so ``{}`` changes nothing) and YAML 1.1's yes/no/on/off for booleans."""
    seen: dict[str, str] = {}
    for text in overrides:
        if "=" not in text:
            continue  # the loader's one-line "expected key=value"
        key, value = (part.strip() for part in text.split("=", 1))
        if key == "recipe":
            raise ValueError(
                f"override {text!r}: the recipe is the RECIPE argument (`symrl train "
                f"{value or 'NAME'}`), not a key"
            )
        if key in seen:
            raise ValueError(
                f"override {key!r} given twice ({seen[key]!r} and {text!r}); give it once"
            )
        seen[key] = text
        if key in taken:
            raise ValueError(f"override {text!r} conflicts with {taken[key]}; give one of them")
        if value.lower() in _YAML11_BOOLS:
            raise ValueError(f"override {text!r}: write true or false")
        if value.replace(" ", "") == "{}":
            raise ValueError(
                f"override {text!r}: an empty mapping changes nothing (mappings merge entry by "
                f"entry); set its entries, e.g. {key}.NAME=VALUE"
            )


def at_least(flag: str, value: int | None, low: int) -> None:
    """A numeric flag below its bound is a one-line input error."""
    if value is not None and value < low:
        raise ValueError(f"{flag} {value}: must be >= {low}")


_NAMED_VALUES = {
    "out": "--out",
    "logdir": "--logdir",
    "map": "--map",
    "resume": "--resume",
    "checkpoint": "CHECKPOINT",
    "recipe": "RECIPE",
    "base": "--base",
    "changes_of": "--changes-of",
}
"""The arguments naming a file or folder, by the flag that gives them (lists such as --recipes
have their own checks)."""


def no_empty_values(args: argparse.Namespace) -> None:
    """An empty path or list (``--out ""``) is an error, not the default or the current
    folder."""
    for name, flag in _NAMED_VALUES.items():
        value = getattr(args, name, None)
        if isinstance(value, str) and not value.strip():
            if name == "recipe" and args.command in ("generalise",):
                flag = "--recipe"
            raise ValueError(
                f"{flag} {value!r}: empty; give a name or path (or leave the flag "
                "out for its default)"
            )


def plannable(source: Any) -> None:
    """Before any work: refuse a map too big for the planner and the sub-goal table, and say so
    when preparing them will take more than a second (see :func:`symrl.world.worldmap.
    check_plannable`). ``source``: a map name, file or loaded map."""
    from symrl.world.worldmap import WorldMap, check_plannable, load_map, planning_note

    world = source if isinstance(source, WorldMap) else load_map(source)
    check_plannable(world)
    note = planning_note(world)
    if note:
        print(f"symrl: note: {note}", file=sys.stderr)


def paper_learner_only(config: Any, command: str) -> None:
    """Refuse a baseline recipe (``baseline.algorithm`` set) in a command that studies the
    paper's learner, in one line naming what it needs that a baseline has not."""
    algorithm = config.baseline.algorithm
    if algorithm is None:
        return
    raise ValueError(
        f"recipe {config.recipe!r} is a deep-RL baseline (baseline.algorithm={algorithm}): "
        f"`symrl {command}` trains its sets as one batch of robots each with its own table "
        "and drives each set's final controller from other starts, and its Table 1 and Fig. 5 "
        "read the experts' neurons and ghosts, all of which only the paper's learner has; "
        f"train the seeds with `symrl baseline {algorithm} --seeds 100-109` or `symrl sweep "
        f"--recipes {algorithm} --seeds 100-109 --out DIR`"
    )
