"""``symrl baseline``: the deep-RL baseline recipes (``sac``, ``ppo``) trained on several seeds,
its flags mapped onto their config keys (:mod:`symrl.studies.baseline_command`); its arguments
beside its handler."""

from __future__ import annotations

import argparse

from symrl.cli.errors import at_least, output_folder
from symrl.cli.stops import stoppable


def add_baseline(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = commands.add_parser(
        "baseline",
        help="deep-RL baselines (SAC, PPO from TorchRL) on the same task, optionally given the "
        "paper's prior knowledge",
        description="Train the recipe sac or ppo (SAC or PPO from TorchRL, the field's "
        "default hyper-parameters) on each seed: the same runs as `symrl train ALGO --seed S "
        "--trials E [key=value ...]` into OUT/seed-S (config.yaml, trials.csv, tb/, "
        "checkpoint.pt for `symrl evaluate`), then a summary of the seeds. From scratch by "
        "default; --residual (baseline.residual=true) and --regions (baseline.regions=true, "
        "knowledge=regions) hand it the paper's priors. `symrl train sac --help-keys` lists "
        "the hyper-parameters (baseline.sac.*, baseline.ppo.*).",
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
        help="baseline.residual=true: act as the shielded fuzzy reflex (steering toward the "
        "goal) plus a learned correction of at most --correction * pi",
    )
    p.add_argument(
        "--correction",
        type=float,
        default=None,
        help="baseline.correction: largest residual correction as a fraction of pi (default "
        "0.25: 45 deg)",
    )
    p.add_argument(
        "--regions",
        action="store_true",
        help="baseline.regions=true and knowledge=regions: append the region id (one-hot, "
        "from the odometry pose and the region rules) to the observation",
    )
    p.add_argument(
        "--envs",
        type=int,
        default=None,
        help="baseline.envs: robots stepped together (default: sac 1, ppo 8)",
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
    """``symrl baseline``: the recipe ALGO trained on each seed (stoppable with one worker: see
    :func:`symrl.cli.stops.stoppable`)."""
    from symrl.studies.baseline_command import baseline_command

    at_least("--episodes", args.episodes, 1)
    at_least("--workers", args.workers, 1)
    at_least("--checkpoint-every", args.checkpoint_every, 1)
    if args.resume and args.overwrite:
        raise ValueError(
            "--resume goes on with the runs in --out, --overwrite replaces them: give one"
        )
    if args.out is not None:
        output_folder("--out", args.out)
    if args.workers != 1:  # worker processes keep their periodic checkpoints
        return baseline_command(args)
    return stoppable(lambda signalled: baseline_command(args, signalled))
