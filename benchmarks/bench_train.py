"""Training throughput, side by side in one run (a script, not a test).

    python benchmarks/bench_train.py [--recipe paper] [--sizes 1,10,100] [--trials 12] [--map WORLD]

Rows, all in robot-steps per CPU second of this process, and as a ratio to the raw env:
- raw env: the Gymnasium env (``Hailu2001Env``) stepped with fixed random actions, no learner;
- bare loop: the reference loop written out by hand (policy, ``env.step_and_maybe_reset``,
  update, trial bookkeeping), no collector;
- TorchRL Collector: the same loop with the steps taken by ``torchrl.collectors.Collector``
  (``frames_per_batch = B``: one env step of the B robots per batch) with its cheapest
  documented options that keep the trials: ``use_buffers=False`` (its buffers are sized by a
  policy call that draws exploration noise), ``return_same_td=True``, ``device="cpu"``,
  ``track_traj_ids=False``, ``trust_policy=True``;
- StepCollector: the same loop driven by the collector train.py uses
  (``symrl.collector.StepCollector``), the bare loop's bookkeeping;
- train.py loop: ``symrl.train.train_batch`` itself (``symrl train`` at B = 1, ``symrl
  study`` with one robot per set at B = 10, 100), its collector ``symrl.collector.StepCollector``.
Every loop trains ``--trials`` trials of robots seeded 0..B-1; the "same trials" column says
whether a loop gave train.py's trials (steps of every trial). Rounds are interleaved (raw, then
each loop at each size, again) so that a change in machine load hits every row alike; the best
of ``--rounds`` is reported, with the spread of the ratio to the raw env over the rounds.

``--compare DIR``: also measure the bare loop and train.py's loop of another checkout of the
repository (e.g. ``git worktree add /tmp/base main``) in the same run, in a child process per
round interleaved with this code's rounds (its ``symrl`` imported from ``DIR``; its recipe
``--compare-recipe``, by default ``--recipe``: a built-in name resolves to the installed
package's recipes, so for another checkout's own recipe pass its file, e.g.
``--compare-recipe /tmp/base/recipes/paper.yaml``). The load
average is printed with the tables (the machine may be shared: ``nice`` does not keep other
processes off the cores).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

OVERRIDES: list[str] = []
"""Overrides every loop's config takes (``--map``: ``env.map=WORLD``)."""


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


class _Learner:
    """Policy, env (with the perception transform), update and trial bookkeeping of B robots,
    built as ``train_batch`` builds them; :meth:`learn` consumes one batch of transitions."""

    def __init__(self, recipe: str, size: int, trials: int) -> None:
        from symrl.learner.config import load_config
        from symrl.train import TrialRecorder, make_env

        config = load_config(recipe, [f"run.trials={trials}", *OVERRIDES])
        self.size, self.trials = size, trials
        seeds = list(range(size))
        env = make_env(config, seeds)
        try:
            from symrl.assembly import build_policy, build_update
        except ImportError:  # a checkout from before the assembly (--compare)
            from symrl.learner.loss import TeseoLoss
            from symrl.learner.policy import MixtureOfExpertsPolicy

            self.policy = MixtureOfExpertsPolicy(config, env.world, seeds)
            self.loss = TeseoLoss(self.policy)
        else:
            self.policy = build_policy(config, env.world, seeds)
            self.loss = build_update(config, self.policy)
        self.env = env.append_transform(self.policy.perception_transform())
        self.recorder = TrialRecorder(size)
        self.steps: list[list[int]] = [[] for _ in seeds]

    def learn(self, td: Any) -> bool:
        """Update from a batch [B] of transitions, close the trials that ended; True when
        every robot has done its trials."""
        from symrl.tensordicts import read

        stats = self.loss(td)
        done = self.recorder.step(td, read(stats, "td_error"))
        if not done.any():
            return False
        ended = np.flatnonzero(done)
        rows = torch.from_numpy(ended)
        records = [self.recorder.finish(b) for b in ended.tolist()]
        totals = np.array([r["total_reinforcement"] for r in records], dtype=np.float32)
        reached = torch.from_numpy(self.recorder.reached.numpy()[ended])
        self.loss.end_trial(rows, torch.from_numpy(totals), reached)
        for j, b in enumerate(ended.tolist()):
            if len(self.steps[b]) < self.trials:
                self.steps[b].append(records[j]["steps"])
        # (a policy that reads is_init begins the trials itself; a second call changes nothing)
        self.policy.begin_trial(rows)
        return all(len(s) >= self.trials for s in self.steps)


def bare_loop(recipe: str, size: int, trials: int) -> tuple[float, list[list[int]]]:
    """The reference loop without a collector: robot-steps per CPU second, trial steps."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    learner = _Learner(recipe, size, trials)
    policy, env = learner.policy, learner.env
    frames, t0 = 0, time.process_time()
    with set_exploration_type(ExplorationType.RANDOM), torch.inference_mode():
        td = env.reset()
        while True:
            policy(td)
            td, following = env.step_and_maybe_reset(td)
            frames += size
            if learner.learn(td):
                break
            td = following
    return frames / (time.process_time() - t0), learner.steps


def torchrl_collector_loop(recipe: str, size: int, trials: int) -> tuple[float, list[list[int]]]:
    """The loop driven by TorchRL's ``Collector``: robot-steps per CPU second, trial steps."""
    from torchrl.collectors import Collector
    from torchrl.envs.utils import ExplorationType

    learner = _Learner(recipe, size, trials)
    t0 = time.process_time()  # the Collector resets the env when it is built
    collector = Collector(
        learner.env,
        learner.policy,
        frames_per_batch=size,
        total_frames=-1,
        exploration_type=ExplorationType.RANDOM,
        use_buffers=False,
        return_same_td=True,
        device="cpu",
        track_traj_ids=False,
        trust_policy=True,
        auto_register_policy_transforms=False,
    )
    frames = 0
    with torch.inference_mode():
        for batch in collector:
            frames += size
            if learner.learn(batch.reshape(size)):  # its batches are [B, 1]
                break
    cpu = time.process_time() - t0
    collector.shutdown()
    return frames / cpu, learner.steps


def step_collector_loop(recipe: str, size: int, trials: int) -> tuple[float, list[list[int]]]:
    """The same loop driven by train.py's collector, ``symrl.collector.StepCollector``, with
    the bare loop's bookkeeping: robot-steps per CPU second, trial steps."""
    from torchrl.envs.utils import ExplorationType

    from symrl.collector import StepCollector

    learner = _Learner(recipe, size, trials)
    collector = StepCollector(learner.env, learner.policy, exploration_type=ExplorationType.RANDOM)
    frames, t0 = 0, time.process_time()
    with torch.inference_mode():
        for batch in collector:
            frames += size
            if learner.learn(batch):
                break
    cpu = time.process_time() - t0
    collector.shutdown()
    return frames / cpu, learner.steps


def train_loop(recipe: str, size: int, trials: int) -> tuple[float, list[list[int]]]:
    """``symrl.train.train_batch``: robot-steps per CPU second of its loop, trial steps."""
    from symrl.learner.config import load_config
    from symrl.train import train_batch

    config = load_config(recipe, [f"run.trials={trials}", *OVERRIDES])
    results = train_batch(config, list(range(size)), progress=False)
    timings = results[0].timings
    return timings["frames"] / timings["cpu_seconds"], [
        [t["steps"] for t in r.trials] for r in results
    ]


LOOPS = {
    "bare loop": bare_loop,
    "TorchRL Collector": torchrl_collector_loop,
    "StepCollector": step_collector_loop,
    "train.py loop": train_loop,
}


def one_round(recipe: str, sizes: list[int], trials: int, loops: list[str]) -> dict[str, Any]:
    """One round of every row: the raw env, then each loop at each batch size."""
    row: dict[str, Any] = {"raw": raw_env(3000)}
    for size in sizes:
        for name in loops:
            rate, steps = LOOPS[name](recipe, size, trials)
            row[f"{name}|{size}"] = rate
            row[f"{name}|{size}|steps"] = steps
    return row


def other_round(
    checkout: str, recipe: str, sizes: list[int], trials: int, world: str | None
) -> dict[str, Any]:
    """:func:`one_round` of the bare loop and train.py's loop with the ``symrl`` of another
    checkout, in a child process (the child's own warm-up is not counted)."""
    env = {**os.environ, "PYTHONPATH": str(Path(checkout).resolve())}
    args = [
        sys.executable,
        __file__,
        "--recipe",
        recipe,
        "--sizes",
        ",".join(map(str, sizes)),
        "--trials",
        str(trials),
        "--one-round",
        *(["--map", world] if world else []),
    ]
    out = subprocess.run(args, env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])


def print_table(
    title: str, rounds: list[dict[str, Any]], sizes: list[int], loops: list[str]
) -> None:
    """Best rate of each row over the rounds, its ratio to the best raw env, the spread of the
    ratio (each round's rate over that round's raw env) and whether the trials were train.py's."""
    raw = max(r["raw"] for r in rounds)
    print(title)
    print("| loop | B | robot-steps/CPU-s | x raw env | spread over rounds | same trials |")
    print("| --- | ---: | ---: | ---: | ---: | --- |")
    print(f"| raw Gymnasium env | 1 | {raw:,.0f} | 1.00 | | |")
    for size in sizes:
        for name in loops:
            key = f"{name}|{size}"
            best = max(r[key] for r in rounds)
            ratios = [r[key] / r["raw"] for r in rounds]
            reference = rounds[0].get(f"train.py loop|{size}|steps")
            same = (
                ""
                if reference is None
                else ("yes" if all(r[f"{key}|steps"] == reference for r in rounds) else "NO")
            )
            print(
                f"| {name} | {size} | {best:,.0f} | {best / raw:.2f} | "
                f"{min(ratios):.2f}-{max(ratios):.2f} | {same} |"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="paper")
    parser.add_argument("--sizes", default="1,10,100", help="batch sizes of the loops")
    parser.add_argument("--trials", type=int, default=12, help="trials of every robot")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--loops", default=",".join(LOOPS), help=f"loops to measure, of: {', '.join(LOOPS)}"
    )
    parser.add_argument(
        "--compare",
        default=None,
        metavar="DIR",
        help="another checkout of the repository, measured in the same run",
    )
    parser.add_argument(
        "--compare-recipe",
        default=None,
        metavar="RECIPE",
        help="the recipe (name or file) the --compare checkout runs (default: --recipe)",
    )
    parser.add_argument(
        "--map",
        default=None,
        metavar="WORLD",
        help="the world every loop trains on (env.map; default: the recipe's); the raw env row "
        "stays the paper's world",
    )
    parser.add_argument("--one-round", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.map:
        from symrl.world import load_map
        from symrl.world.map_fields import MapError

        try:
            load_map(args.map)
        except MapError as error:
            parser.error(f"--map: {error}")
        OVERRIDES.append(f"env.map={args.map}")
    torch.set_num_threads(1)
    sizes = [int(s) for s in args.sizes.split(",")]
    loops = [name.strip() for name in args.loops.split(",")]
    unknown = [name for name in loops if name not in LOOPS]
    if unknown:
        parser.error(f"--loops: unknown loop {unknown[0]!r}; choose from {', '.join(LOOPS)}")
    if args.one_round:  # a child of --compare: the loops every checkout has
        loops = ["bare loop", "train.py loop"]
    for name in loops:  # warm-up: imports, first calls
        LOOPS[name](args.recipe, 1, 1)
    if args.one_round:
        print(json.dumps(one_round(args.recipe, sizes, args.trials, loops)))
        return
    mine: list[dict[str, Any]] = []
    other: list[dict[str, Any]] = []
    for _ in range(args.rounds):
        if args.compare:
            recipe = args.compare_recipe or args.recipe
            other.append(other_round(args.compare, recipe, sizes, args.trials, args.map))
        mine.append(one_round(args.recipe, sizes, args.trials, loops))
    load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    how = (
        f"recipe {args.recipe}{', map ' + args.map if args.map else ''}, {args.trials} trials "
        "a robot; robot-steps per CPU second, "
        f"best of {args.rounds} rounds; load average {load} (1, 5, 15 min)"
    )
    if args.compare:
        print_table(f"{args.compare}: {how}", other, sizes, ["bare loop", "train.py loop"])
        print()
    print_table(f"this checkout: {how}", mine, sizes, loops)


if __name__ == "__main__":
    main()
