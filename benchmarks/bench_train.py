"""Training throughput, side by side in one run (a script, not a test).

    python benchmarks/bench_train.py [--recipe paper] [--sizes 1,10,100] [--steps 600]

Rows, all in robot-steps (set-steps) per CPU second of this process:
- raw env: the Gymnasium env (``Hailu2001Env``) stepped with fixed random actions, no learner;
- training loop at B = 1 (``symrl train``) and at B = 10, 100 (``symrl study``: one robot per
  set): ``symrl.train.train_batch`` itself, with the per-step breakdown (policy, update, the
  env's ``_step``, the rest: TorchRL's step, step_mdp and resets around it, trial bookkeeping)
  measured inside that loop.
The ratio column divides by the raw env. Rounds are interleaved (raw, B=1, B=10, ... again) so
that a change in machine load hits every row alike; the best of ``--rounds`` is reported.

``--compare DIR``: also measure the code of another checkout of the repository (e.g. the main
branch: ``git worktree add /tmp/base main``) in the same run, in a child process per round
interleaved with this code's rounds (its ``symrl`` imported from ``DIR``); both tables are
printed, the other checkout's first. The load average is printed with the tables (the
machine may be shared: ``nice`` does not keep other processes off the cores).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch


def raw_env(steps: int) -> float:
    """Robot-steps per CPU second of the Gymnasium env alone."""
    import gymnasium

    import symrl  # noqa: F401 - registers the env

    env = gymnasium.make("symrl/Hailu2001-v0").unwrapped
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-0.6, 0.6, (steps, 1)).astype(np.float32)
    t0 = time.process_time()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return steps / (time.process_time() - t0)


def _timed(cls: type, name: str, key: str, totals: dict[str, float]):
    """Wrap ``cls.name`` to add its CPU time to ``totals[key]``; returns the original."""
    original = getattr(cls, name)

    def wrapper(*args, **kwargs):
        t0 = time.process_time()
        out = original(*args, **kwargs)
        totals[key] += time.process_time() - t0
        return out

    setattr(cls, name, wrapper)
    return original


def training_loop(recipe: str, size: int, steps: int) -> dict[str, float]:
    """Robot-steps per CPU second of ``train_batch`` with ``size`` robots, and its breakdown."""
    import symrl.train as train_module
    from symrl.learner.config import load_config
    from symrl.learner.loss import TeseoLoss
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.world.batched_env import BatchedWorldEnv

    totals: dict[str, float] = defaultdict(float)
    parts = ((MixtureOfExpertsPolicy, "forward", "policy"), (TeseoLoss, "forward", "update"),
             (BatchedWorldEnv, "_step", "env"))  # fmt: skip
    originals = [_timed(cls, name, key, totals) for cls, name, key in parts]
    trials = max(1, steps // 28)  # about 28 actions a trial: about `steps` batch steps
    config = load_config(recipe, [f"run.trials={trials}"])
    try:
        t0 = time.process_time()
        results = train_module.train_batch(config, list(range(size)), progress=False)
        cpu = time.process_time() - t0
    finally:
        for (cls, name, _), original in zip(parts, originals, strict=True):
            setattr(cls, name, original)
    frames = results[0].timings["frames"]
    batch_steps = frames / size
    out = {"steps_per_cpu_s": frames / cpu, "batch_steps": batch_steps}
    rest = cpu - sum(totals.values())
    for key, value in (*totals.items(), ("rest", rest)):
        out[f"{key}_us"] = value / batch_steps * 1e6
    return out


def one_round(recipe: str, sizes: list[int], steps: int) -> dict[str, dict[str, float]]:
    """One round of every row: the raw env, then the training loop at each batch size."""
    row = {"raw": {"steps_per_cpu_s": raw_env(3000)}}
    for size in sizes:
        row[f"B={size}"] = training_loop(recipe, size, steps)
    return row


def other_round(checkout: str, recipe: str, sizes: list[int], steps: int) -> dict:
    """:func:`one_round` with the ``symrl`` of another checkout, in a child process (the
    child's own warm-up call is not counted)."""
    env = {**os.environ, "PYTHONPATH": str(Path(checkout).resolve())}
    args = [sys.executable, __file__, "--recipe", recipe, "--sizes", ",".join(map(str, sizes)),
            "--steps", str(steps), "--one-round"]  # fmt: skip
    out = subprocess.run(args, env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])


def keep_best(best: dict[str, dict[str, float]], row: dict[str, dict[str, float]]) -> None:
    for key, value in row.items():
        if value["steps_per_cpu_s"] > best.get(key, {}).get("steps_per_cpu_s", 0):
            best[key] = value


def print_table(title: str, best: dict[str, dict[str, float]], sizes: list[int]) -> None:
    raw = best["raw"]["steps_per_cpu_s"]
    print(title)
    print("| loop | robot-steps/CPU-s | x raw env | policy us | update us | env us | rest us |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    print(f"| raw Gymnasium env | {raw:,.0f} | 1.00 | | | | |")
    for size in sizes:
        r = best[f"B={size}"]
        print(
            f"| training loop, B = {size} | {r['steps_per_cpu_s']:,.0f} | "
            f"{r['steps_per_cpu_s'] / raw:.2f} | {r['policy_us']:.0f} | {r['update_us']:.0f} | "
            f"{r['env_us']:.0f} | {r['rest_us']:.0f} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="paper_map")
    parser.add_argument("--sizes", default="1,10,100", help="batch sizes of the training loop")
    parser.add_argument("--steps", type=int, default=600, help="about this many batch steps")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--compare", default=None, metavar="DIR",
                        help="another checkout of the repository, measured in the same run")
    parser.add_argument("--one-round", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    torch.set_num_threads(1)
    sizes = [int(s) for s in args.sizes.split(",")]
    training_loop(args.recipe, 1, 60)  # warm-up: imports, first calls
    if args.one_round:  # a child of --compare: one round as JSON
        print(json.dumps(one_round(args.recipe, sizes, args.steps)))
        return
    best: dict[str, dict[str, float]] = {}
    other: dict[str, dict[str, float]] = {}
    for _ in range(args.rounds):
        if args.compare:
            keep_best(other, other_round(args.compare, args.recipe, sizes, args.steps))
        keep_best(best, one_round(args.recipe, sizes, args.steps))
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    rounds = f"best of {args.rounds} rounds; load average {load} (1, 5, 15 min)"
    if args.compare:
        print_table(f"{args.compare}: recipe {args.recipe}; robot-steps per CPU second "
                    f"({rounds})", other, sizes)  # fmt: skip
        print()
    print_table(f"this checkout: recipe {args.recipe}; robot-steps per CPU second ({rounds})",
                best, sizes)
    print("(us: CPU microseconds per batch step, i.e. per step of all B robots)")


if __name__ == "__main__":
    main()
