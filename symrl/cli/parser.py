"""The ``symrl`` parser, assembled from each command's own arguments, and the reading of a
command line with it (negative poses, ``key=value`` overrides after options)."""

from __future__ import annotations

import argparse
import re

from symrl.cli.baselines import add_baseline
from symrl.cli.driving import add_drive, add_evaluate
from symrl.cli.errors import one_line_errors
from symrl.cli.planning import add_plan
from symrl.cli.studying import add_ablate, add_generalise, add_study
from symrl.cli.sweeping import add_sweep
from symrl.cli.training import add_train

_COMMANDS = (
    add_drive,
    add_train,
    add_evaluate,
    add_study,
    add_ablate,
    add_plan,
    add_baseline,
    add_generalise,
    add_sweep,
)
"""Each command's arguments and handler, in the order ``symrl --help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The ``symrl`` parser: one subcommand per job, each with ``handler`` set."""
    parser = argparse.ArgumentParser(
        prog="symrl",
        description="Symbolic structures in numeric reinforcement (Hailu, 2001): "
        "a robot that learns a short, safe path in a handful of trials. Outputs: "
        "`train` writes runs/RECIPE__sSEED__TIME/, every other command results/COMMAND.../ "
        "(see --out of each).",
    )
    one_line_errors(parser)
    from symrl.about import __version__

    parser.add_argument(
        "--version",
        action="version",
        version=f"symrl {__version__}",
        help="print the version and exit",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in _COMMANDS:
        add(sub)
    for each in sub.choices.values():
        one_line_errors(each)
    return parser


def parse_command(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """``argv`` read by ``parser``, usage errors in one line (exit 2)."""
    args, extra = parser.parse_known_args(negative_values(argv))
    # argparse cannot take positional key=value overrides after options (`study R --sets 2 k=v`)
    if extra:
        if hasattr(args, "overrides") and all("=" in e and not e.startswith("-") for e in extra):
            args.overrides = [*args.overrides, *extra]
        elif hasattr(args, "overrides") and not extra[0].startswith("-"):
            parser.error(
                f"argument {extra[0]!r}: expected key=value (an override such as update.gamma=0.9)"
            )
        else:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    return args


_NEGATIVE_VALUE = re.compile(r"-\.?\d[\d.eE+-]*(,[^,]*)+")
"""A negative pose such as ``-1.4,0,0``, which argparse would take for an option."""


def negative_values(argv: list[str]) -> list[str]:
    """``--start -1.4,0,0`` as ``--start=-1.4,0,0``: argparse reads a value that starts with
    a minus sign and is not a plain number as an option (and then says the flag is missing
    its argument)."""
    out: list[str] = []
    for token in argv:
        previous = out[-1] if out else ""
        if previous.startswith("--") and "=" not in previous and _NEGATIVE_VALUE.fullmatch(token):
            out[-1] = f"{previous}={token}"
        else:
            out.append(token)
    return out
