"""The commands that train many sets and compare them: ``symrl study`` (one recipe's
repeatability), ``ablate`` (every recipe on the same seeds) and ``generalise`` (the learned
controller elsewhere), each command's arguments beside its handler."""

from __future__ import annotations

import argparse
from pathlib import Path

from symrl.cli.errors import (
    at_least,
    check_overrides,
    output_folder,
    paper_learner_only,
    plannable,
    recipe_argument,
)
from symrl.locks import holding

MAX_SETS = 10_000
"""Most sets of one study (each a robot with its own world and learner in memory)."""
MAX_WORKERS = 1024
_WORKERS_HELP = (
    "worker processes, each training its share of the sets as one batch "
    "(default: one per CPU core; set k is the same run whatever the split)"
)


def sets_and_trials(args: argparse.Namespace) -> None:
    """``--sets``, ``--trials``, ``--seed`` and ``--workers`` within their bounds."""
    at_least("--sets", args.sets, 1)
    at_least("--trials", args.trials, 1)
    at_least("--seed", args.seed, 0)
    for flag, value, high in (
        ("--sets", args.sets, MAX_SETS),
        ("--trials", args.trials, 1_000_000),
        ("--seed", args.seed, 2**63 - 1 - MAX_SETS),
        ("--workers", args.workers, MAX_WORKERS),
    ):
        if value is not None and value > high:
            raise ValueError(f"{flag} {value}: must be <= {high}")
    at_least("--workers", args.workers, 1)


def add_study(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "study", help="repeatability study: N sets x M trials (Table 1, Figs 5-9)"
    )
    p.add_argument("recipe", help="recipe name (paper, paper_literal, ...) or YAML file")
    p.add_argument("--sets", type=int, default=10, help="sets, each a fresh learner (default 10)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None, help=_WORKERS_HELP)
    p.add_argument("--seed", type=int, default=100, help="first seed; set k uses seed + k")
    p.add_argument("--map", default=None, help="built-in map name or map file (env.map)")
    p.add_argument("--out", default=None, help="results folder (default results/study-RECIPE)")
    p.add_argument(
        "--overwrite", action="store_true", help="replace a finished or stopped study in --out"
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="go on with the study stopped in --out (Ctrl-C, SIGTERM, SIGHUP or a "
        "kill): the same command and --resume give the table of a run never stopped",
    )
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_study)


def _study(args: argparse.Namespace) -> int:
    from symrl.studies.repeatability import study_command

    sets_and_trials(args)
    recipe_argument(args.recipe)
    taken = {"run.trials": "--trials (the study's budget)", "run.seed": "--seed (set k: seed + k)"}
    if args.map is not None:
        taken["env.map"] = f"--map {args.map}"
    check_overrides(args.overrides, taken)
    args.out = args.out or f"results/study-{Path(args.recipe).stem}"
    if args.resume and args.overwrite:
        raise ValueError(
            "--resume goes on with the stopped study in --out, --overwrite starts afresh: give one"
        )
    from symrl.learner.config import load_config

    config = load_config(args.recipe, args.overrides)
    paper_learner_only(config, "study")
    output_folder("--out", args.out, ("table1.json",), args.overwrite, "study")
    plannable(config.env.map if args.map is None else args.map)
    from symrl.studies import checkpointing

    settings = {
        "recipe": args.recipe,
        "sets": args.sets,
        "trials": args.trials,
        "seed": args.seed,
        "map": args.map,
        "overrides": list(args.overrides),
    }
    with (
        holding(args.out, "--out"),
        checkpointing.running(args.out, "study", settings, args.resume, args.overwrite) as going_on,
    ):
        if args.overwrite and not going_on:
            checkpointing.forget_kept(Path(args.out) / "sets")
        return study_command(args)


def add_ablate(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser("ablate", help="the study for every recipe with the same seeds")
    p.add_argument("--sets", type=int, default=10, help="sets per recipe (default 10)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None, help=_WORKERS_HELP)
    p.add_argument("--seed", type=int, default=100, help="first seed; set k uses seed + k")
    p.add_argument(
        "--recipes",
        default=None,
        help="comma-separated recipes (default: all six; with --changes-of: none)",
    )
    p.add_argument(
        "--changes-of",
        default=None,
        metavar="RECIPE",
        help="RECIPE, then RECIPE with each setting in which it differs from --base "
        "put back in turn, and with experts.learning=false; writes changes.md "
        "(paired differences over the sets)",
    )
    p.add_argument(
        "--ladder",
        action="store_true",
        help="the knowledge ladder: the best recipe of each rung (reflex_only, "
        "paper_literal, paper, paper_passages, paper_map) on the same seeds; writes "
        "ladder.md",
    )
    p.add_argument(
        "--base",
        default=None,
        help="the recipe --changes-of puts settings back to (default paper_literal)",
    )
    p.add_argument(
        "--map",
        default="hailu2001",
        help="built-in map name or map file (env.map; default hailu2001)",
    )
    p.add_argument(
        "--maps",
        default=None,
        metavar="M1,M2,...",
        help="with --ladder: the ladder on each of these worlds (built-in names, "
        "suite/world names or map files), one sub-folder each, and one table and "
        "figure of them all (ladder-worlds.md, ladder-worlds.png)",
    )
    p.add_argument(
        "--out", default="results/ablate", help="results folder (default results/ablate)"
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="go on with the ablation stopped in --out (same settings)",
    )
    p.set_defaults(handler=_ablate)


def _ablate(args: argparse.Namespace) -> int:
    from symrl.studies.ablation import ablate_command

    sets_and_trials(args)
    if args.base is not None and not args.changes_of:
        raise ValueError(
            f"--base {args.base}: only with --changes-of (the recipe whose settings "
            "it puts back); without it --base would be ignored"
        )
    args.base = args.base or "paper_literal"
    _recipe_list("--recipes", args.recipes)
    _paper_learners("ablate", (args.recipes or "").split(",") + [args.changes_of or ""])
    output_folder("--out", args.out)
    if args.maps is not None:
        from symrl.studies.ladder_worlds import ladder_worlds_command, parse_maps

        if not args.ladder or args.map != "hailu2001":  # a --map other than the default
            raise ValueError(
                f"--maps {args.maps!r}: runs the ladder on several worlds; give "
                "it with --ladder and without --map"
            )
        for name in parse_maps(args.maps):
            plannable(name)
        return ladder_worlds_command(args)
    plannable(args.map)
    if args.resume and not Path(args.out).is_dir():
        raise ValueError(f"--resume: --out {args.out!r} does not exist; nothing to go on with")
    with holding(args.out, "--out"):
        return ablate_command(args)


def _paper_learners(command: str, recipes: list[str]) -> None:
    """None of ``recipes`` (names or files; empty ones skipped) is a baseline."""
    from symrl.learner.config import load_config

    for name in recipes:
        if name.strip():
            paper_learner_only(load_config(name.strip()), command)


def _recipe_list(flag: str, value: str | None) -> None:
    """A comma-separated list of recipes names each one (no empty name)."""
    if value is not None and not all(part.strip() for part in value.split(",")):
        raise ValueError(
            f"{flag} {value!r}: "
            + ("names no recipe" if not value.strip(", ") else "an empty name in the list")
            + "; name them (e.g. paper,reflex_only) or leave the flag out for all six"
        )


def add_generalise(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "generalise", help="learned controller from other starts, new obstacle, noise"
    )
    p.add_argument("--recipe", default="paper", help="recipe name or YAML file (default paper)")
    p.add_argument("--sets", type=int, default=5, help="sets, each a fresh learner (default 5)")
    p.add_argument("--trials", type=int, default=20, help="trials per set (default 20)")
    p.add_argument("--workers", type=int, default=None, help=_WORKERS_HELP)
    p.add_argument(
        "--seed", type=int, default=100, help="first seed; set k uses seed + k (default 100)"
    )
    p.add_argument(
        "--map",
        default="hailu2001",
        help="built-in map name or map file (env.map; default hailu2001)",
    )
    p.add_argument(
        "--out", default="results/generalise", help="results folder (default results/generalise)"
    )
    p.add_argument(
        "--overwrite", action="store_true", help="replace the results of an earlier run in --out"
    )
    p.set_defaults(handler=_generalise)


def _generalise(args: argparse.Namespace) -> int:
    from symrl.studies.generalisation import generalise_command

    sets_and_trials(args)
    _paper_learners("generalise", [args.recipe])
    output_folder("--out", args.out, ("generalise.json",), args.overwrite, "generalise")
    plannable(args.map)
    with holding(args.out, "--out"):
        return generalise_command(args)
