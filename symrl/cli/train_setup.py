"""The run a ``symrl train`` makes: its config, seed, world and folder, from a recipe and the
command's flags or from a stopped run's folder (``--resume``), and the lines that report it.

Imported by the command when it runs: it brings torch with it."""

from __future__ import annotations

import argparse
import os
import signal
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from symrl.cli.errors import check_overrides, output_folder
from symrl.learner.config import RunConfig, config_from_dict, config_to_dict, load_config
from symrl.world.worldmap import WorldMap, load_map


@dataclass
class TrainRun:
    """What ``run_one`` is given: ``state`` is the saved state of a resumed run, else None."""

    config: RunConfig
    seed: int
    world: WorldMap
    logdir: str
    state: dict[str, Any] | None = None


def resumed(args: argparse.Namespace) -> TrainRun:
    """The run in ``--resume RUN_DIR``, its own config (``--trials`` may extend the budget)."""
    given = [
        name
        for name, value in (
            ("RECIPE", args.recipe),
            ("--seed", args.seed),
            ("--map", args.map),
            ("--logdir", args.logdir),
            ("key=value", args.overrides),
            ("--overwrite", args.overwrite),
        )
        if value
    ]
    if given:
        raise ValueError(
            f"--resume {args.resume!r}: a resumed run keeps its own config; drop "
            f"{', '.join(given)} (only --trials may extend the budget)"
        )
    from symrl.studies.learners import load_run

    config, seed, state, world = load_run(args.resume, adopt=args.adopt_checkpoint)
    if args.trials is not None:
        data = config_to_dict(config)
        data["run"]["trials"] = args.trials
        config = config_from_dict(data, recipe=config.recipe)
    done = len(state["trials"])
    if done >= config.run.trials:
        raise ValueError(
            f"--resume {args.resume!r}: the run has done {done} of {config.run.trials} "
            "trials; pass a larger --trials to go on"
        )
    return TrainRun(config, seed, world, args.resume, state)


def fresh(args: argparse.Namespace) -> TrainRun:
    """A new run of RECIPE with the overrides and the flags that set config keys."""
    if args.recipe is None:
        raise ValueError("train: a RECIPE is needed (e.g. `symrl train paper`)")
    check_overrides(
        args.overrides or [],
        {
            key: f"{flag} {value}"
            for key, flag, value in (
                ("run.trials", "--trials", args.trials),
                ("run.seed", "--seed", args.seed),
                ("env.map", "--map", args.map),
            )
            if value is not None
        },
    )
    if args.logdir is not None:
        output_folder("--logdir", args.logdir)
    overrides = list(args.overrides or [])
    for flag, key in (
        (args.trials, "run.trials"),
        (args.seed, "run.seed"),
        (args.map, "env.map"),
    ):
        if flag is not None:
            overrides.append(f"{key}={flag}")
    config = load_config(args.recipe, overrides)
    stamp = time.strftime("%Y%m%d-%H%M%S") + f"-{time.time_ns() // 1000 % 1_000_000:06d}"
    logdir = args.logdir or f"runs/{config.recipe}__s{config.run.seed}__{stamp}-{os.getpid()}"
    return TrainRun(config, config.run.seed, load_map(config.env.map), logdir)


def stopped_line(run: TrainRun, trials: list[dict[str, Any]], signum: int) -> str:
    """What a run stopped by the signal ``signum`` kept, and how to go on with it."""
    if not trials and run.state is None:
        saved = "no trial finished, nothing to resume"
    else:
        saved = f"saved in {run.logdir}/; go on with: symrl train --resume {run.logdir}"
    return (
        f"symrl train: stopped by {signal.Signals(signum).name} after {len(trials)} of "
        f"{run.config.run.trials} finished trials; {saved}"
    )


def summary_lines(run: TrainRun, result: Any) -> str:
    """The finished run in two lines: its last trials, and what it wrote."""
    trials = result.trials
    last = trials[-5:]
    neurons = f", {trials[-1]['neurons']} neurons" if "neurons" in trials[-1] else ""
    return (
        f"{run.config.recipe} (seed {run.seed}): {len(trials)} trials, "
        f"{result.timings['steps_per_second']:.0f} steps/s; last trial {trials[-1]['steps']} "
        f"actions, total {trials[-1]['total_reinforcement']:.2f}{neurons}; "
        f"last-{len(last)} mean {np.mean([t['steps'] for t in last]):.1f} actions, "
        f"total {np.mean([t['total_reinforcement'] for t in last]):.2f}, "
        f"goal {sum(t['reached_goal'] for t in trials)}/{len(trials)}\n"
        f"wrote {run.logdir}/ (config.yaml, trials.csv, checkpoint.pt, trajectory.png, tb/)"
    )
