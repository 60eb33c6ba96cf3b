"""``symrl baseline``: deep-RL baselines (SAC, PPO) on the same task, its arguments beside its
handler."""

from __future__ import annotations

import argparse

from symrl.cli.errors import output_folder
from symrl.cli.stops import stoppable


def add_baseline(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "baseline",
        help="deep-RL baselines (SAC, PPO from TorchRL) on the same task, optionally given the "
        "paper's prior knowledge",
        description="Train SAC or PPO (TorchRL) on the paper's world, one run folder per seed "
        "(OUT/seed-S: config.yaml, trials.csv, tb/, checkpoint.pt for `symrl evaluate`). "
        "From scratch by default; --residual and --regions hand it the paper's priors. "
        "SAC defaults (Stable-Baselines3 / Haarnoja et al. 2018): buffer 1e6, batch 256, "
        "100 random steps first, Adam 3e-4, gamma 0.99, tau 0.005, 1 gradient step per "
        "transition, learned temperature, 2x256 ReLU, 1 env. PPO defaults (CleanRL): 2048 "
        "transitions per update from 8 envs, 10 epochs, minibatch 64, Adam 3e-4, gamma 0.99, "
        "GAE 0.95, clip 0.2, 2x64 tanh.",
    )
    p.add_argument("algorithm", choices=["sac", "ppo"], help="sac or ppo")
    p.add_argument(
        "--episodes",
        type=int,
        default=20,
        help="training budget in episodes (= trials; default 20, the paper's)",
    )
    p.add_argument("--seeds", default="100", help="seeds: a range 100-104 and/or a list 100,105")
    p.add_argument(
        "--residual",
        action="store_true",
        help="act as the shielded fuzzy reflex (steering toward the goal) plus a "
        "learned correction of at most --correction * pi",
    )
    p.add_argument(
        "--correction",
        type=float,
        default=None,
        help="largest residual correction as a fraction of pi (default 0.25: 45 deg)",
    )
    p.add_argument(
        "--regions",
        action="store_true",
        help="append the region id (one-hot, from the odometry pose) to the observation",
    )
    p.add_argument(
        "--envs", type=int, default=None, help="robots stepped together (default: sac 1, ppo 8)"
    )
    p.add_argument(
        "--workers", type=int, default=1, help="seeds trained in parallel processes (default 1)"
    )
    p.add_argument(
        "--map", default="hailu2001", help="built-in map name or map file (default hailu2001)"
    )
    p.add_argument(
        "--out", default=None, help="results folder (default results/baseline-ALGO-VARIANT)"
    )
    p.add_argument("--overwrite", action="store_true", help="replace runs already in --out")
    p.add_argument(
        "--resume",
        action="store_true",
        help="go on with the runs already in --out (same settings; --episodes may "
        "extend the budget); seeds without a run there start fresh",
    )
    p.add_argument(
        "--checkpoint-every",
        type=int,
        default=50,
        metavar="N",
        help="save the whole run state every N trials (default 50), on Ctrl-C / "
        "SIGTERM (one worker) and at the end",
    )
    p.set_defaults(handler=_baseline)


def _baseline(args: argparse.Namespace) -> int:
    """``symrl baseline`` (stoppable with one worker: see :func:`symrl.cli.stops.stoppable`)."""
    from symrl.studies.baseline_command import baseline_command

    if args.out is not None:
        output_folder("--out", args.out)
    if args.workers != 1:  # worker processes keep their periodic checkpoints
        return baseline_command(args)
    return stoppable(lambda signalled: baseline_command(args, signalled))
