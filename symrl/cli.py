"""The ``symrl`` command line: one subcommand per job, each a thin layer over the public API.

Parsing lives here; the work lives in the modules named by each handler, imported lazily so
``symrl --help`` is instant and a command only pays for the libraries it uses.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence


def parse_pose(text: str) -> tuple[float, float, float]:
    """Read ``X,Y,HEADING`` (metres, metres, radians) or ``X,Y`` (heading 0)."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--start {text!r}: expected X,Y,HEADING as numbers, e.g. 0,0,0"
        ) from None
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"--start {text!r}: expected X,Y[,HEADING] finite numbers")
    if len(values) == 2:
        values.append(0.0)
    return values[0], values[1], values[2]


def _drive(args: argparse.Namespace) -> int:
    from symrl.drive import drive_command

    return drive_command(args)


def _train(args: argparse.Namespace) -> int:
    import os
    import time

    import numpy as np

    from symrl.learner.config import describe_keys, load_config
    from symrl.runs import RunWriter
    from symrl.train import train
    from symrl.world.worldmap import load_map

    if args.help_keys:
        print(describe_keys())
        return 0
    if args.recipe is None:
        raise ValueError("train: a RECIPE is needed (e.g. `symrl train paper`)")
    overrides = list(args.overrides or [])
    for flag, key in ((args.trials, "run.trials"), (args.seed, "run.seed"), (args.map, "env.map")):
        if flag is not None:
            overrides.append(f"{key}={flag}")
    config = load_config(args.recipe, overrides)
    stamp = time.strftime("%Y%m%d-%H%M%S") + f"-{time.time_ns() // 1000 % 1_000_000:06d}"
    logdir = args.logdir or f"runs/{config.recipe}__s{config.run.seed}__{stamp}-{os.getpid()}"
    writer = RunWriter(logdir, config, load_map(config.env.map), overwrite=args.overwrite)

    def on_trial(b: int, record: dict, policy) -> None:
        writer.trial(record, last=record["trial"] == config.run.trials)

    try:
        result = train(config, progress=True, on_trial=on_trial)
    finally:
        writer.close()
    writer.finish(result.policy, result.seed)
    trials, last = result.trials, result.trials[-5:]
    print(
        f"{config.recipe} (seed {config.run.seed}): {len(trials)} trials, "
        f"{result.timings['steps_per_second']:.0f} steps/s; last trial {trials[-1]['steps']} "
        f"actions, total {trials[-1]['total_reinforcement']:.2f}, {trials[-1]['neurons']} "
        f"neurons; last-{len(last)} mean {np.mean([t['steps'] for t in last]):.1f} actions, "
        f"total {np.mean([t['total_reinforcement'] for t in last]):.2f}, "
        f"goal {sum(t['reached_goal'] for t in trials)}/{len(trials)}"
    )
    print(f"wrote {logdir}/ (config.yaml, trials.csv, checkpoint.pt, trajectory.png, tb/)")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib.pyplot as plt

    from symrl.evaluate import evaluate
    from symrl.figures import trajectory_figure
    from symrl.runs import load_checkpoint

    policy, config = load_checkpoint(args.checkpoint)
    world = None
    if args.map is not None:
        from symrl.world.worldmap import load_map

        world = load_map(args.map)
    (record,) = evaluate(policy, config, starts=[args.start], seed=args.seed, world=world)
    out = Path(args.out) if args.out else Path(args.checkpoint).parent
    out.mkdir(parents=True, exist_ok=True)
    title = f"greedy: {record['steps']} actions, total {record['total_reinforcement']:.2f}"
    fig = trajectory_figure(world or policy.world, record, title=title)
    fig.savefig(out / "evaluate.png", dpi=120)
    plt.close(fig)
    print(
        f"greedy trial: {record['steps']} actions, total {record['total_reinforcement']:.2f}, "
        f"{record['collisions']} collisions, reached goal {record['reached_goal']}, "
        f"path {record['path_length']:.2f} m"
    )
    print(f"wrote {out / 'evaluate.png'}")
    return 0


def _study(args: argparse.Namespace) -> int:
    from symrl.studies.repeatability import study_command

    return study_command(args)


def _ablate(args: argparse.Namespace) -> int:
    from symrl.studies.ablation import ablate_command

    return ablate_command(args)


def _plan(args: argparse.Namespace) -> int:
    from symrl.studies.planner import plan_command

    return plan_command(args)


def _baseline(args: argparse.Namespace) -> int:
    from symrl.studies.ppo import baseline_command

    return baseline_command(args)


def _generalise(args: argparse.Namespace) -> int:
    from symrl.studies.generalisation import generalise_command

    return generalise_command(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="symrl",
        description="Symbolic structures in numeric reinforcement (Hailu, 2001): "
        "a robot that learns a short, safe path in a handful of trials.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("drive", help="let the fuzzy reflex drive one trial and save its path")
    p.add_argument("--start", type=parse_pose, default=None, help="start pose X,Y,HEADING")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", default="out/drive", help="output folder (default out/drive)")
    p.add_argument("--map", default="hailu2001", help="built-in map name or map file")
    p.add_argument("--no-noise", action="store_true", help="turn every noise source off")
    p.add_argument(
        "--shield",
        type=float,
        nargs="?",
        const=0.06,
        default=None,
        metavar="MARGIN",
        help="veto moves into walls with the IR shield (margin in m, default 0.06)",
    )
    p.set_defaults(handler=_drive)

    p = sub.add_parser(
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
    p.add_argument("--help-keys", action="store_true", help="list every config key and exit")
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_train)

    p = sub.add_parser("evaluate", help="drive a saved controller greedily and save its path")
    p.add_argument("checkpoint", help="checkpoint file written by `symrl train`")
    p.add_argument("--start", type=parse_pose, default=None, help="start pose X,Y,HEADING")
    p.add_argument("--seed", type=int, default=0, help="random seed for the world's noise")
    p.add_argument("--map", default=None, help="drive in another map (default: its own)")
    p.add_argument("--out", default=None, help="output folder (default: beside the checkpoint)")
    p.set_defaults(handler=_evaluate)

    p = sub.add_parser("study", help="repeatability study: N sets x M trials (Table 1, Figs 5-9)")
    p.add_argument("recipe")
    p.add_argument("--sets", type=int, default=10)
    p.add_argument("--trials", type=int, default=20)
    p.add_argument("--workers", type=int, default=1,
                   help="worker processes, each training its share of the sets as one batch "
                   "(default 1: all sets in one batch)")
    p.add_argument("--seed", type=int, default=100, help="first seed; set k uses seed + k")
    p.add_argument("--map", default=None, help="built-in map name or map file (env.map)")
    p.add_argument("--out", default=None, help="results folder (default results/study-RECIPE)")
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides")
    p.set_defaults(handler=_study)

    p = sub.add_parser("ablate", help="the study for every recipe with the same seeds")
    p.add_argument("--sets", type=int, default=10)
    p.add_argument("--trials", type=int, default=20)
    p.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("--recipes", default=None, help="comma-separated subset of recipes")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (env.map; default hailu2001)")
    p.add_argument("--out", default="results/ablate")
    p.set_defaults(handler=_ablate)

    p = sub.add_parser("plan", help="shortest collision-free path to the goal (the optimum)")
    p.add_argument("--map", default="hailu2001")
    p.add_argument("--start", type=parse_pose, default=None)
    p.add_argument("--out", default="results/plan")
    p.set_defaults(handler=_plan)

    p = sub.add_parser("baseline", help="baselines on the same env (ppo)")
    p.add_argument("algorithm", choices=["ppo"])
    p.add_argument("--episodes", type=int, default=20, help="training budget in episodes")
    p.add_argument("--seeds", default="100", help="comma-separated seeds")
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (default hailu2001)")
    p.add_argument("--out", default="results/baseline-ppo")
    p.set_defaults(handler=_baseline)

    p = sub.add_parser(
        "generalise", help="learned controller from other starts, new obstacle, noise"
    )
    p.add_argument("--recipe", default="paper")
    p.add_argument("--sets", type=int, default=5)
    p.add_argument("--trials", type=int, default=20)
    p.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--seed", type=int, default=100)
    p.add_argument("--map", default="hailu2001",
                   help="built-in map name or map file (env.map; default hailu2001)")
    p.add_argument("--out", default="results/generalise")
    p.set_defaults(handler=_generalise)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    # argparse cannot take positional key=value overrides after options (`study R --sets 2 k=v`)
    if extra:
        if hasattr(args, "overrides") and all("=" in e and not e.startswith("-") for e in extra):
            args.overrides = [*args.overrides, *extra]
        else:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return int(args.handler(args) or 0)
    except (ValueError, FileNotFoundError, FileExistsError) as err:
        # Configuration and input errors: one clear line, no deep traceback.
        print(f"symrl {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
