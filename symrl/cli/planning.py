"""``symrl plan``: the shortest collision-free path (and, asked, the reward's optimum), its
arguments beside its handler."""

from __future__ import annotations

import argparse

from symrl.cli.errors import output_folder, plannable
from symrl.cli.poses import START_HELP, naming_start, parse_pose
from symrl.locks import holding


def add_plan(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "plan",
        help="shortest collision-free path to the goal (fewest actions; not the reward's "
        "optimum, which also pays for heading and wall distance)",
    )
    p.add_argument(
        "--map", default="hailu2001", help="built-in map name or map file (default hailu2001)"
    )
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument(
        "--out",
        default="results/plan",
        help="results folder for plan.json and plan.png (default results/plan)",
    )
    p.add_argument(
        "--overwrite", action="store_true", help="replace a plan.json / plan.png already in --out"
    )
    p.add_argument(
        "--reward",
        action="store_true",
        help="also search for the best total reinforcement of a noise-free trial "
        "(writes reward_optimum.json and reward_optimum.png)",
    )
    p.add_argument(
        "--beam",
        type=int,
        default=100,
        help="with --reward: partial sequences kept per action (default 100)",
    )
    p.add_argument(
        "--headings",
        type=int,
        default=144,
        help="with --reward: headings tried per action (default 144, every 2.5 degrees)",
    )
    p.set_defaults(handler=_plan)


def _plan(args: argparse.Namespace) -> int:
    from symrl.studies.plan import plan_command
    from symrl.world import load_map

    for flag, value, low in (("--beam", args.beam, 1), ("--headings", args.headings, 4)):
        if not low <= value <= 100_000:
            raise ValueError(f"{flag} {value}: must be an integer from {low} to 100000")
    results: tuple[str, ...] = ("plan.json", "plan.png")
    if args.reward:
        results += ("reward_optimum.json", "reward_optimum.png")
    output_folder("--out", args.out, results, args.overwrite, "plan")
    world = load_map(args.map)
    plannable(world)
    with holding(args.out, "--out"), naming_start(args.start):
        return plan_command(args, world)
