"""The ``symrl`` command line: one subcommand per job, each a thin layer over the public API.

Each command's arguments are built beside its handler (:mod:`symrl.cli.driving`,
``training``, ``studying``, ``planning``, ``baselines``, ``sweeping``), assembled by
:mod:`symrl.cli.parser`; input errors and stops end a command in one line
(:mod:`symrl.cli.errors`, :mod:`symrl.cli.stops`). The work lives in the modules each handler
names, imported lazily so ``symrl --help`` is instant and a command only pays for the
libraries it uses.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from symrl.cli.errors import input_error, no_empty_values
from symrl.cli.parser import build_parser, parse_command
from symrl.cli.poses import MAX_COORD, START_HELP, format_pose, parse_pose
from symrl.cli.stops import RESUMABLE, signals_stop, stopped

__all__ = ["MAX_COORD", "START_HELP", "build_parser", "format_pose", "main", "parse_pose"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; ``argv`` None: this process is the command (``symrl ...``), which
    then also keeps Ray out (unless it is ``sweep``), imports what the command needs with the
    garbage collector paused."""
    import time

    started = time.perf_counter()
    command_line = argv is None
    parser = build_parser()
    args = parse_command(parser, sys.argv[1:] if argv is None else list(argv))
    args.started = started  # the command's wall time is counted from here
    if command_line:
        from symrl.cli.process import set_up

        set_up(args.command)
    try:
        no_empty_values(args)
        with signals_stop(args.command in RESUMABLE):
            code = int(args.handler(args) or 0)
    except (ValueError, OSError) as err:  # configuration and input errors: one clear line
        code = input_error(args.command, err)
    except KeyboardInterrupt as err:  # a command that does not catch Ctrl-C itself
        code = stopped(args.command, err, getattr(args, "out", None))
    return code
