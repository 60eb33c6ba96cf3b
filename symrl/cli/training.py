"""``symrl train``: its arguments beside its handler (the run's set-up and report:
:mod:`symrl.cli.train_setup`)."""

from __future__ import annotations

import argparse
import sys

from symrl.cli.errors import at_least, plannable, recipe_argument
from symrl.cli.stops import stoppable


def add_train(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "train",
        help="train a recipe online, trial by trial",
        description="Train a recipe online. Config keys are overridden as key=value "
        "(e.g. update.gamma=0.9 shield.enabled=false); --help-keys lists every key with its "
        "default and meaning.",
    )
    p.add_argument("recipe", nargs="?", help="recipe name (paper, paper_literal, ...) or YAML file")
    p.add_argument("--trials", type=int, default=None, help="number of trials (recipe default)")
    p.add_argument("--seed", type=int, default=None, help="random seed (recipe default)")
    p.add_argument("--map", default=None, help="built-in map name or map file (env.map)")
    p.add_argument("--logdir", default=None, help="run folder (default runs/RECIPE__sSEED__TIME)")
    p.add_argument("--overwrite", action="store_true", help="replace a run already in --logdir")
    p.add_argument(
        "--resume",
        default=None,
        metavar="RUN_DIR",
        help="go on with the run in RUN_DIR from its last checkpoint (its own config; "
        "--trials may extend the budget)",
    )
    p.add_argument(
        "--checkpoint-every",
        type=int,
        default=None,
        metavar="N",
        help="write the resumable checkpoint every N trials (default 1; a baseline's, which "
        "holds its replay buffer, 50; always at the end and when stopped by Ctrl-C or SIGTERM)",
    )
    p.add_argument(
        "--adopt-checkpoint",
        action="store_true",
        help="with --resume: go on even if checkpoint.pt's recipe, seed, map or "
        "settings differ from the folder's config.yaml (the checkpoint's win)",
    )
    p.add_argument(
        "--help-keys",
        action="store_true",
        help="list every config key with its value (RECIPE's and the overrides', "
        "given one; else the defaults) and exit",
    )
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_train)


def _train(args: argparse.Namespace) -> int:
    """``symrl train`` (stoppable: see :func:`symrl.cli.stops.stoppable`)."""
    return stoppable(lambda signalled: _train_run(args, signalled))


def _train_run(args: argparse.Namespace, signalled: list[int]) -> int:
    from symrl.cli.train_setup import fresh, resumed, stopped_line, summary_lines
    from symrl.learner.config import describe_keys, load_config
    from symrl.studies.learners import run_recipe

    recipe_argument(args.recipe)
    if args.help_keys:  # with a RECIPE (and key=value), that recipe's values
        print(describe_keys(load_config(args.recipe, args.overrides) if args.recipe else None))
        return 0
    at_least("--trials", args.trials, 1)
    at_least("--seed", args.seed, 0)
    at_least("--checkpoint-every", args.checkpoint_every, 1)
    if args.adopt_checkpoint and args.resume is None:
        raise ValueError("--adopt-checkpoint: only with --resume RUN_DIR")
    run = resumed(args) if args.resume is not None else fresh(args)
    if run.config.options.enabled:
        plannable(run.world)
    result = run_recipe(
        run.config,
        run.logdir,
        world=run.world,
        overwrite=args.overwrite,
        resume=run.state,
        seed=run.seed,
        checkpoint_every=args.checkpoint_every,
        stop=lambda: bool(signalled),
    )
    if result.timings.get("stopped"):
        print(stopped_line(run, result.trials, signalled[0]), file=sys.stderr)
        return 128 + int(signalled[0])
    print(summary_lines(run, result))
    return 0
