"""Steps per second of the full training loop beside the raw env, and where each step's time goes.

    python benchmarks/bench_train.py [--recipe paper_literal] [--trials 10] [--repeats 3]

Prints, in one run (so machine load affects every line alike):
  1. the raw gymnasium env loop (random small actions, no learner),
  2. a TorchRL Collector over the same env with a trivial policy (the Collector's floor),
  3. the full ``symrl.train.train`` loop (Collector + policy + TESEO update + trial records),
  4. the same learner stepped by hand (``env.step_and_maybe_reset``, no Collector, no records),
and for the full loop the time per step in: env physics, gate (region + input coding), winner
search, growth (new neurons, incl. the reflex), the policy's forward, the update, trial
bookkeeping, and what is left (Collector / TorchRL overhead). Timers are wrapped around class
methods, so the breakdown run is a little slower than the untimed one printed above it.

Rates are given in wall-clock and in this process's CPU time: on a shared machine (other jobs
running) the CPU-time figures are the stable ones; the breakdown uses CPU time.
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


def _timed(cls, name: str, label: str):
    original = getattr(cls, name)

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
    from symrl.learner.experts import GrowingRBFExpert
    from symrl.learner.loss import TeseoLoss
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.train import TrialRecorder
    from symrl.world.env import Hailu2001Env

    patches = [
        _timed(Hailu2001Env, "step", "env step (physics, sensors, reward)"),
        _timed(MixtureOfExpertsPolicy, "forward", "policy forward (incl. its perception)"),
        _timed(TeseoLoss, "update", "update (incl. perceiving the next state)"),
        _timed(MixtureOfExpertsPolicy, "region_of", "  gate: region"),
        _timed(MixtureOfExpertsPolicy, "encode", "  gate: input coding x"),
        _timed(GrowingRBFExpert, "nearest", "  winner search"),
        _timed(MixtureOfExpertsPolicy, "new_neuron_action", "  growth: new action (reflex)"),
        _timed(GrowingRBFExpert, "add", "  growth: add neuron"),
        _timed(TrialRecorder, "step", "trial bookkeeping"),
    ]
    try:
        yield
    finally:
        for cls, name, original in patches:
            setattr(cls, name, original)


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

    raw = median([raw_env(2000) for _ in range(args.repeats)])
    floor = median([collector_floor(config, 1500) for _ in range(args.repeats)])
    hand = median([hand_loop(config) for _ in range(args.repeats)])
    runs = [full_loop(config) for _ in range(args.repeats)]
    full = median([r[0] for r in runs])
    frames, trials = runs[0][1], runs[0][2]
    print(f"recipe {args.recipe}, {args.trials} trials ({frames} steps), median of {args.repeats}")
    print(f"{'loop':<46}{'steps/s':>9}{'us/step':>9}{'CPU steps/s':>13}{'CPU us/step':>13}")
    for label, (wall, cpu) in [
        ("raw gymnasium env (random actions)", raw),
        ("Collector + trivial policy (TorchRL floor)", floor),
        ("full training loop (symrl.train.train)", full),
        ("same learner, hand loop without Collector", hand),
    ]:
        print(f"{label:<46}{wall:>9.0f}{1e6 / wall:>9.0f}{cpu:>13.0f}{1e6 / cpu:>13.0f}")
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
    print(f"\nwhere a step's CPU time goes (instrumented run, {frames} steps, "
          f"{1e6 * total / frames:.0f} us/step):")  # fmt: skip
    top = ("env step", "policy forward", "update", "trial bookkeeping")
    accounted = sum(v for k, v in TIMES.items() if k.startswith(top))
    for label, seconds in TIMES.items():
        print(f"  {label:<50}{1e6 * seconds / frames:>8.0f} us/step  ({CALLS[label]} calls)")
    rest = 1e6 * (total - accounted) / frames
    print(f"  {'Collector / TorchRL overhead (the rest)':<50}{rest:>8.0f} us/step")


if __name__ == "__main__":
    main()
