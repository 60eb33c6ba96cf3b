"""Training throughput, side by side in one run (a script, not a test).

    python benchmarks/bench_train.py [--recipe paper] [--sizes 1,10,100] [--steps 600]

Rows, all in robot-steps (set-steps) per CPU second of this process:
- raw env: the Gymnasium env (``Hailu2001Env``) stepped with fixed random actions, no learner;
- training loop at B = 1 (``symrl train``) and at B = 10, 100 (``symrl study``: one robot per
  set): ``symrl.train.train_batch`` itself, with the per-step breakdown (policy, update, the
  env's ``step``, the rest: Collector, trial bookkeeping) measured inside that loop.
The ratio column divides by the raw env. Rounds are interleaved (raw, B=1, B=10, ... again) so
that a change in machine load hits every row alike; the best of ``--rounds`` is reported.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="paper")
    parser.add_argument("--sizes", default="1,10,100", help="batch sizes of the training loop")
    parser.add_argument("--steps", type=int, default=600, help="about this many batch steps")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(1)
    sizes = [int(s) for s in args.sizes.split(",")]
    training_loop(args.recipe, 1, 60)  # warm-up: imports, first calls
    best: dict[str, dict[str, float]] = {}
    for _ in range(args.rounds):
        rate = raw_env(3000)
        if rate > best.get("raw", {}).get("steps_per_cpu_s", 0):
            best["raw"] = {"steps_per_cpu_s": rate}
        for size in sizes:
            row = training_loop(args.recipe, size, args.steps)
            key = f"B={size}"
            if row["steps_per_cpu_s"] > best.get(key, {}).get("steps_per_cpu_s", 0):
                best[key] = row
    raw = best["raw"]["steps_per_cpu_s"]
    print(f"recipe {args.recipe}; robot-steps per CPU second (best of {args.rounds} rounds)")
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
    print("(us: CPU microseconds per batch step, i.e. per step of all B robots)")


if __name__ == "__main__":
    main()
