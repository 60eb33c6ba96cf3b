"""``symrl drive`` (the fuzzy reflex drives one trial) and ``symrl evaluate`` (a saved
controller drives one greedy trial): each command's arguments beside its handler."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from symrl.cli.errors import at_least, output_folder
from symrl.cli.poses import START_HELP, format_pose, naming_start, parse_pose
from symrl.locks import holding


def add_drive(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser("drive", help="let the fuzzy reflex drive one trial and save its path")
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--out",
        default="results/drive",
        help="output folder for path.png and trial.json (default results/drive)",
    )
    p.add_argument(
        "--overwrite", action="store_true", help="replace a path.png / trial.json already in --out"
    )
    p.add_argument(
        "--map", default="hailu2001", help="built-in map name or map file (default hailu2001)"
    )
    p.add_argument("--no-noise", action="store_true", help="turn every noise source off")
    p.add_argument(
        "--shield",
        type=float,
        nargs="?",
        const=0.06,
        default=None,
        metavar="MARGIN",
        help="veto moves into walls with the IR shield (margin in m, below the IR range "
        "0.5 m; 0.06 if given without a value)",
    )
    p.set_defaults(handler=_drive)


def _drive(args: argparse.Namespace) -> int:
    from symrl.drive import drive_command
    from symrl.world.robot import RobotConfig

    at_least("--seed", args.seed, 0)
    from symrl.knowledge.shield import ShieldConfig

    if args.shield is not None:
        ShieldConfig(margin=args.shield)  # its own checks first
    ir_range = RobotConfig().ir_range
    if args.shield is not None and math.isfinite(args.shield) and args.shield >= ir_range:
        raise ValueError(
            f"--shield {args.shield:g}: the margin must be below the IR range {ir_range:g} m "
            "(the shield sees walls only by their IR reflectance)"
        )
    output_folder("--out", args.out, ("path.png", "trial.json"), args.overwrite, "drive")
    with holding(args.out, "--out"), naming_start(args.start):
        return drive_command(args)


def add_evaluate(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser("evaluate", help="drive a saved controller greedily and save its path")
    p.add_argument(
        "checkpoint", help="checkpoint file written by `symrl train` or `symrl baseline`"
    )
    p.add_argument("--start", type=parse_pose, default=None, help=START_HELP)
    p.add_argument("--seed", type=int, default=0, help="random seed for the world's noise")
    p.add_argument(
        "--map", default=None, help="drive in another map (default: its own); with --other-map"
    )
    p.add_argument(
        "--other-map",
        action="store_true",
        help="with --map: drive in a map other than the one the controller learned "
        "in (it keeps the learned map's regions and goal; the output names both)",
    )
    p.add_argument(
        "--out",
        default=None,
        help="output folder for evaluate.png (default: beside the checkpoint)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an evaluate.png already in the output folder",
    )
    p.set_defaults(handler=_evaluate)


def _evaluate(args: argparse.Namespace) -> int:
    from symrl.cli.evaluating import driven_in, load_controller, save_figure

    at_least("--seed", args.seed, 0)
    controller = load_controller(args.checkpoint)
    out = Path(args.out) if args.out else Path(args.checkpoint).parent
    output_folder("--out", out, ("evaluate.png",), args.overwrite, "evaluate")
    trained_on = controller.world
    world, other = driven_in(trained_on, args.map, args.other_map)
    if other:
        print(
            f"symrl evaluate: note: trained on map {trained_on.name!r}, driving in map "
            f"{world.name!r} (told {trained_on.name!r}'s regions and goal)",
            file=sys.stderr,
        )
    with holding(out, "--out"), naming_start(args.start):
        record = controller.greedy(args.start, args.seed, world)
    save_figure(world, record, out)
    home = world.start
    start = args.start if args.start is not None else (home.x, home.y, home.heading)
    print(
        f"greedy trial from {format_pose(start)}: {record['steps']} actions, "
        f"total {record['total_reinforcement']:.2f}, "
        f"{record['collisions']} collisions, reached goal {record['reached_goal']}, "
        f"path {record['path_length']:.2f} m"
        + (f"; trained on {trained_on.name}, driven in {world.name}" if other else "")
    )
    print(f"wrote {out / 'evaluate.png'}")
    return 0
