"""Steps per second of the full training loop beside the raw env, and where each step's time goes.

    python benchmarks/bench_train.py [--recipe paper_literal] [--trials 10] [--repeats 3]

Prints, in one run (so machine load affects every line alike), rates in process CPU time and
their ratios (the machine is shared: wall-clock rates are printed too, but only CPU time is
stable):
  1. the raw gymnasium env loop (random small actions, no learner, no TorchRL),
  2. a TorchRL Collector over the same env (``symrl.train.make_env``, the training loop's
     Collector settings) with a do-nothing policy: the ceiling of any learner in this loop,
  3. the full ``symrl.train.train`` loop (Collector + policy + TESEO update + trial records),
  4. the same learner stepped by hand (``env.step_and_maybe_reset``, no Collector, no records);
then, for the full loop, the CPU time per step and its share in: env physics, TorchRL's env
glue (``step_and_maybe_reset`` around the physics), the policy's forward, the update (and
inside it the gate, winner search, growth and the fuzzy reflex), trial bookkeeping, and what is
left (the Collector: batch stacking, iteration). Timers are wrapped around methods, so the
instrumented run is a little slower than the untimed one.

The rounds of 1-4 are interleaved (1, 2, 3, 4, 1, 2, ...) and the median of each is printed.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from contextlib import contextmanager

import gymnasium
import numpy as np
import torch

import symrl
from symrl.learner.config import load_config


def raw_env(steps: int) -> tuple[float, float]:
    env = gymnasium.make(symrl.ENV_ID)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    t, c = time.perf_counter(), time.process_time()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-0.3, 0.3, 1).astype(np.float32))
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t), steps / (time.process_time() - c)


def collector_floor(config, steps: int) -> float:
    from tensordict.nn import TensorDictModuleBase
    from torchrl.collectors import Collector
    from torchrl.data import Bounded, Composite

    from symrl.train import make_env

    class Zero(TensorDictModuleBase):
        in_keys = ["sonar"]
        out_keys = ["action"]

        def forward(self, td):
            td.set("action", torch.zeros(1))
            return td

    policy = Zero()
    policy.spec = Composite(action=Bounded(-np.pi, np.pi, shape=(1,)))
    collector = Collector(
        make_env(config), policy, frames_per_batch=1, total_frames=steps,
        track_traj_ids=False, return_same_td=True, auto_register_policy_transforms=False,
    )  # fmt: skip
    collector._exclude_private_keys = False  # as in symrl.train.train
    t, c = time.perf_counter(), time.process_time()
    n = sum(1 for _ in collector)
    rates = n / (time.perf_counter() - t), n / (time.process_time() - c)
    collector.shutdown()
    return rates


def hand_loop(config) -> tuple[float, float]:
    """The same learner without the Collector: ``env.step_and_maybe_reset`` by hand."""
    from symrl.learner.loss import TeseoLoss
    from symrl.train import make_env, make_policy, seed_everything

    seed_everything(config.run.seed)
    env = make_env(config)
    env.set_seed(config.run.seed)
    base = env._env.unwrapped
    policy = make_policy(config, world=base.world, robot=base.robot)
    loss = TeseoLoss(policy)
    td = env.reset()
    trials = frames = 0
    t, c = time.perf_counter(), time.process_time()
    while trials < config.run.trials:
        policy(td)
        transition, td = env.step_and_maybe_reset(td)
        loss.update(transition)
        frames += 1
        if transition.get(("next", "done")).item():
            loss.end_trial({"reached_goal": transition.get(("next", "reached_goal")).item(),
                            "total_reinforcement": -1e9})  # fmt: skip
            trials += 1
    return frames / (time.perf_counter() - t), frames / (time.process_time() - c)


def full_loop(config) -> tuple[tuple[float, float], int, list]:
    from symrl.train import train

    result = train(config, progress=False)
    t = result.timings
    LOOP_SECONDS.append(t["cpu_seconds"])
    return (t["frames"] / t["seconds"], t["frames"] / t["cpu_seconds"]), t["frames"], result.trials


LOOP_SECONDS: list[float] = []
TIMES: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)


LABELS: list[str] = []
TIMES_ORDER: list[str] = []  # labels in the order they were wrapped (the printed order)


def _timed(cls, name: str, label: str):
    original = getattr(cls, name, None)
    if original is None:  # an older tree without this method (bench kept usable across commits)
        return cls, name, None
    TIMES_ORDER.append(label)

    def wrapper(*args, **kwargs):
        t = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            TIMES[label] += time.process_time() - t
            CALLS[label] += 1

    setattr(cls, name, wrapper)
    return cls, name, original


@contextmanager
def instrumented():
    from torchrl.envs import EnvBase

    from symrl.knowledge.reflex import FuzzyReflex
    from symrl.learner.experts import GrowingRBFExpert
    from symrl.learner.loss import TeseoLoss
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.train import TrialRecorder
    from symrl.world.env import Hailu2001Env

    patches = [
        _timed(EnvBase, "step_and_maybe_reset", ENV_ALL),
        _timed(Hailu2001Env, "step", PHYSICS),
        _timed(MixtureOfExpertsPolicy, "forward", "policy forward (incl. its perception)"),
        _timed(TeseoLoss, "update", "update (incl. perceiving the next state)"),
        _timed(MixtureOfExpertsPolicy, "region_of", "  gate: region"),
        _timed(MixtureOfExpertsPolicy, "encode", "  gate: input coding x"),
        _timed(GrowingRBFExpert, "nearest", "  winner search"),
        _timed(MixtureOfExpertsPolicy, "new_neuron_action", "  growth: new action"),
        _timed(FuzzyReflex, "angle", "    fuzzy reflex (one sample)"),
        _timed(GrowingRBFExpert, "add", "  growth: add neuron"),
        _timed(TrialRecorder, "step", "trial bookkeeping"),
    ]
    LABELS[:] = [label for label in TIMES_ORDER]
    try:
        yield
    finally:
        for cls, name, original in reversed(patches):
            if original is not None:
                setattr(cls, name, original)


ENV_ALL = "env: TorchRL step_and_maybe_reset"
PHYSICS = "env physics (Hailu2001Env.step)"
GLUE = "env: TorchRL glue around the physics"
TOP = (GLUE, PHYSICS, "policy forward", "update", "trial bookkeeping")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="paper_literal")
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(args.recipe, [f"run.trials={args.trials}"])

    full_loop(load_config(args.recipe, ["run.trials=1"]))  # warm-up (imports, first calls)

    def median(runs):
        return tuple(statistics.median(r[k] for r in runs) for k in (0, 1))

    rounds: dict[str, list] = defaultdict(list)
    runs = []
    for _ in range(args.repeats):  # interleaved, so load changes hit every loop alike
        rounds["raw"].append(raw_env(2000))
        rounds["floor"].append(collector_floor(config, 1500))
        runs.append(full_loop(config))
        rounds["full"].append(runs[-1][0])
        rounds["hand"].append(hand_loop(config))
    rates = {k: median(v) for k, v in rounds.items()}
    frames, trials = runs[0][1], runs[0][2]
    print(f"recipe {args.recipe}, {args.trials} trials ({frames} steps), median of {args.repeats}")
    print(
        f"{'loop':<46}{'steps/s':>9}{'CPU steps/s':>13}{'CPU us/step':>13}"
        f"{'/ raw env':>11}{'/ floor':>9}"
    )
    for key, label in [
        ("raw", "raw gymnasium env (random actions)"),
        ("floor", "Collector + do-nothing policy (the floor)"),
        ("full", "full training loop (symrl.train.train)"),
        ("hand", "same learner, hand loop without Collector"),
    ]:
        wall, cpu = rates[key]
        print(
            f"{label:<46}{wall:>9.0f}{cpu:>13.0f}{1e6 / cpu:>13.0f}"
            f"{cpu / rates['raw'][1]:>11.3f}{cpu / rates['floor'][1]:>9.2f}"
        )
    print(
        f"last trial: {trials[-1]['steps']} actions, total "
        f"{trials[-1]['total_reinforcement']:.2f}, {trials[-1]['neurons']} neurons"
    )

    TIMES.clear()
    CALLS.clear()
    with instrumented():
        _, frames, _ = full_loop(config)
    # the loop's own time (train() starts its clock after building env, policy and Collector)
    total = LOOP_SECONDS[-1]
    TIMES[GLUE] = TIMES.pop(ENV_ALL) - TIMES[PHYSICS]
    CALLS[GLUE] = CALLS.pop(ENV_ALL)
    print(
        f"\nwhere a step's CPU time goes (instrumented run, {frames} steps, "
        f"{1e6 * total / frames:.0f} us/step):"
    )
    accounted = sum(v for k, v in TIMES.items() if k.startswith(TOP))
    order = [GLUE, PHYSICS] + [k for k in LABELS if k not in (ENV_ALL, PHYSICS)]
    for label in (k for k in order if k in TIMES):
        seconds = TIMES[label]
        print(
            f"  {label:<50}{1e6 * seconds / frames:>8.0f} us/step {100 * seconds / total:>5.1f}%"
            f"  ({CALLS[label]} calls)"
        )
    rest = total - accounted
    print(
        f"  {'Collector (batch stacking, iteration): the rest':<50}{1e6 * rest / frames:>8.0f}"
        f" us/step {100 * rest / total:>5.1f}%"
    )


if __name__ == "__main__":
    main()
