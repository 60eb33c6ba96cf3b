"""``symrl sweep``: a grid of runs (recipes x seeds x maps), its arguments beside its handler."""

from __future__ import annotations

import argparse

from symrl.cli.errors import check_overrides, output_folder, plannable
from symrl.locks import holding


def add_sweep(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "sweep",
        help="a grid of runs: recipes x seeds x maps, one run folder each, one merged table",
        description="Train every recipe x seed x map (the key=value overrides apply to all) "
        "into OUT/runs/RECIPE__MAP__sSEED/ as `symrl train` writes it; runs already finished "
        "there are kept. Writes OUT/summary.md, summary.json and comparison.png.",
    )
    p.add_argument("--recipes", required=True, help="comma-separated recipes (paper,reflex_only)")
    p.add_argument("--seeds", required=True, help="seeds: a range 100-102 and/or a list 100,105")
    p.add_argument(
        "--maps",
        default="hailu2001",
        help="comma-separated built-in maps or map files (default hailu2001)",
    )
    p.add_argument("--trials", type=int, default=20, help="trials per run (default 20)")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="parallel runs (default: 1 local, every CPU with ray)",
    )
    p.add_argument(
        "--backend",
        choices=["local", "ray"],
        default="local",
        help='local process pool (default) or Ray tasks (pip install "symrl[ray]")',
    )
    p.add_argument("--out", required=True, help="sweep folder")
    p.add_argument(
        "--resume",
        action="store_true",
        help="go on with the sweep stopped in --out: its unfinished runs go on from "
        "their last checkpoints",
    )
    p.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides for all")
    p.set_defaults(handler=_sweep)


def _sweep(args: argparse.Namespace) -> int:
    from symrl.studies.sweep import sweep_command

    check_overrides(
        args.overrides, {"run.trials": "--trials", "run.seed": "--seeds", "env.map": "--maps"}
    )
    output_folder("--out", args.out)
    for name in (args.maps or "").split(","):
        if name.strip():
            plannable(name.strip())
    with holding(args.out, "--out"):
        return sweep_command(args)
