"""Throughput of ``symrl baseline sac|ppo``, scratch and residual, side by side in one run.

    python benchmarks/bench_baselines.py [--trees before=/tmp/symrl-before,after=.] [--rounds 2]

Each row is one short ``train_baseline`` run (seed 0, progress bar off, one torch thread) in a
fresh subprocess whose ``PYTHONPATH`` puts the given source tree first, so two versions of the
code (e.g. ``git archive main | tar -x -C /tmp/symrl-before``) are measured in the same run on
the same machine. Reported: env steps per CPU second of that process over the whole run, and
the CPU time per env step spent acting (the actor), stepping the env (with its transforms) and
observing (buffer and gradient steps). Budgets: SAC 600-odd steps (its first 100 transitions
have no update, so the rate slightly flatters SAC); PPO 2 updates of 2,048 transitions.
Rounds are interleaved (tree A, tree B, tree A, ...) so that a change in machine load hits every
tree alike; the best of ``--rounds`` is reported.

Last, the floor of SAC's gradient step on this CPU: one ``SACLoss`` step (loss, backward, Adam,
target update) on a fixed batch of 256, on 1 and on 2 torch threads (wall time), beside the
time its matrix products alone would take at the rate a 256 x 256 x 256 product runs here on
one thread (16 forward-equivalents of the 2 x 256 networks per step: 8 forward passes, the
backward about as much again).
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

from bench_train import _timed  # the same CPU-time wrapper (this script's folder)

CASES = (("sac", False, 3), ("sac", True, 20), ("ppo", False, 21), ("ppo", True, 140))
"""(algorithm, residual, episodes): about 600 SAC steps, 2 PPO updates."""


def one(algorithm: str, residual: bool, episodes: int) -> dict[str, float | str]:
    """Run in this process; the rates of one case."""
    import torch
    from torchrl.envs import TransformedEnv

    import symrl
    from symrl.learner.config import load_config
    from symrl.studies import baseline
    from symrl.studies.baseline_agent import algorithms

    agent_cls = algorithms()[algorithm]
    totals: dict[str, float] = defaultdict(float)
    _timed(agent_cls, "act", "act", totals)
    _timed(agent_cls, "observe", "observe", totals)
    _timed(TransformedEnv, "step_and_maybe_reset", "env", totals)
    torch.set_num_threads(1)
    t0 = time.process_time()
    overrides = ["run.seed=0", f"run.trials={episodes}", f"baseline.residual={residual}"]
    result = baseline.train_baseline(load_config(algorithm, overrides), progress=False)
    cpu = time.process_time() - t0
    frames = result.timings["frames"]
    out: dict[str, float | str] = {
        "source": str(Path(symrl.__file__).parent.parent),
        "frames": frames,
        "steps_per_cpu_s": frames / cpu,
    }
    for key in ("act", "env", "observe"):
        out[f"{key}_ms"] = totals[key] / frames * 1e3
    out["rest_ms"] = (cpu - sum(totals.values())) / frames * 1e3
    return out


def measure(tree: str, algorithm: str, residual: bool, episodes: int) -> dict[str, float | str]:
    """One case in a subprocess with ``tree`` first on the import path."""
    env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())}
    cmd = [sys.executable, __file__, "--one", algorithm, str(int(residual)), str(episodes)]
    done = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def sac_update_floor(
    threads: int = 1, n_obs: int = 27, hidden: int = 256, batch: int = 256
) -> dict[str, float]:
    """Wall ms of one SAC gradient step on ``threads`` torch threads, and of its matrix products
    at this CPU's one-thread matmul rate."""
    import torch
    from tensordict import TensorDict

    from symrl.studies.sac import SACAgent, SACConfig

    torch.set_num_threads(1)
    torch.manual_seed(0)
    x, w = torch.randn(hidden, hidden), torch.randn(hidden, hidden)
    agent = SACAgent(SACConfig(hidden=hidden, batch_size=batch), n_obs, 1)
    td = TensorDict(
        {
            "observation": torch.randn(batch, n_obs),
            "control": torch.rand(batch, 1) * 2 - 1,
            "next": {
                "observation": torch.randn(batch, n_obs),
                "reward": torch.randn(batch, 1),
                "done": torch.zeros(batch, 1, dtype=torch.bool),
                "terminated": torch.zeros(batch, 1, dtype=torch.bool),
            },
        },
        [batch],
    )

    def step() -> None:
        out = agent.loss(td)
        total = out["loss_actor"] + out["loss_qvalue"] + out["loss_alpha"]
        agent.optim.zero_grad()
        total.backward()
        agent.optim.step()
        agent.target.step()

    rates, steps = [], []
    for _ in range(3):
        torch.set_num_threads(1)
        t0 = time.perf_counter()
        for _ in range(200):
            x @ w
        rates.append(2 * hidden**3 * 200 / (time.perf_counter() - t0))
        torch.set_num_threads(threads)
        t0 = time.perf_counter()
        for _ in range(30):
            step()
        steps.append((time.perf_counter() - t0) / 30)
    torch.set_num_threads(1)
    macs = (n_obs + 1) * hidden + hidden * hidden + hidden * 2  # one net, one sample
    flops = 16 * macs * batch * 2
    return {
        "step_ms": min(steps) * 1e3,
        "gflops": max(rates) / 1e9,
        "matmul_floor_ms": flops / max(rates) * 1e3,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--trees",
        default="current=.",
        help="NAME=PATH,... source trees to compare (default: this one)",
    )
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        algorithm, residual, episodes = args.one
        print(json.dumps(one(algorithm, residual == "1", int(episodes))))
        return
    trees = dict(part.split("=", 1) for part in args.trees.split(","))
    best: dict[tuple[str, str, bool], dict[str, float | str]] = {}
    for _ in range(args.rounds):
        for algorithm, residual, episodes in CASES:
            for name, tree in trees.items():
                row = measure(tree, algorithm, residual, episodes)
                key = (name, algorithm, residual)
                if row["steps_per_cpu_s"] > best.get(key, {}).get("steps_per_cpu_s", 0):
                    best[key] = row
    first = next(iter(trees))
    print(f"env steps per CPU second (best of {args.rounds} rounds); ms: CPU per env step")
    print(
        "| baseline | tree | steps/CPU-s | x " + first + " | act ms | env ms | observe ms "
        "| rest ms |"
    )
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for algorithm, residual, _ in CASES:
        base = float(best[(first, algorithm, residual)]["steps_per_cpu_s"])
        for name in trees:
            r = best[(name, algorithm, residual)]
            label = f"{algorithm} {'residual' if residual else 'scratch'}"
            print(
                f"| {label} | {name} | {r['steps_per_cpu_s']:.0f} "
                f"| {float(r['steps_per_cpu_s']) / base:.2f} | {r['act_ms']:.2f} "
                f"| {r['env_ms']:.2f} | {r['observe_ms']:.2f} | {r['rest_ms']:.2f} |"
            )
    for name, tree in trees.items():
        print(f"{name}: {best[(name, CASES[0][0], CASES[0][1])]['source']} ({tree})")
    for threads in (1, 2):
        floor = sac_update_floor(threads)
        print(
            f"SAC gradient step (batch 256, 2 x 256 nets, this tree), {threads} torch thread(s): "
            f"{floor['step_ms']:.1f} wall ms (best of 3 x 30); its matrix products alone at "
            f"{floor['gflops']:.0f} GFLOP/s (one thread): {floor['matmul_floor_ms']:.1f} ms, "
            f"i.e. at most {1e3 / floor['matmul_floor_ms']:.0f} SAC steps/s at one update each"
        )


if __name__ == "__main__":
    main()
