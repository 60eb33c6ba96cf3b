"""How fast is the world? `Hailu2001Env`, `BatchedWorldEnv` at B = 1, 10, 100, sensing, baselines.

The machine is shared, so absolute numbers drift. To keep them comparable the measurements are
interleaved (round robin over the cases, best of ``--repeats`` rounds), timed in CPU time of this
process (``time.process_time``, which ignores the time other processes hold the cores), and also
printed as ratios to baselines measured in the same run (gymnasium's CartPole-v1 step and a
trivial numpy step). The batched env is counted in robot-steps (B per ``env.step``), driven by a
fixed action tensor through ``env.step`` and ``env.step_and_maybe_reset`` (TorchRL's rollout
loop, with per-robot resets), so the figure includes TorchRL's per-step overhead.

    python benchmarks/bench_env.py [--steps 5000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import gymnasium
import numpy as np
import torch

from symrl.world.batched_env import BatchedWorldEnv
from symrl.world.env import Hailu2001Env


def timed(fn: Callable[[int], None], n: int) -> float:
    """Calls per CPU-second of ``fn(n)`` (which makes n calls)."""
    t0 = time.process_time()
    fn(n)
    return n / max(time.process_time() - t0, 1e-9)


def env_loop(env: Hailu2001Env, policy: str) -> Callable[[int], None]:
    rng = np.random.default_rng(0)

    def run(n: int) -> None:
        obs, _ = env.reset(seed=0)
        actions = rng.uniform(-math.pi, math.pi, (n, 1)).astype(np.float32)
        for k in range(n):
            if policy == "goal":  # turn toward the goal, a little jitter: trial-like paths
                actions[k, 0] = obs["goal"][1] + 0.3 * (actions[k, 0] / math.pi)
            obs, _, terminated, truncated, _ = env.step(actions[k])
            if terminated or truncated:
                obs, _ = env.reset()

    return run


def sense_loop(env: Hailu2001Env) -> Callable[[int], None]:
    rng = np.random.default_rng(1)
    poses = []
    while len(poses) < 512:
        x, y = rng.uniform(-1.5, 5.55), rng.uniform(-4.0, 2.5)
        if env.world.in_free_area(x, y) and env.clearance(x, y) > env.robot.radius:
            poses.append((x, y, rng.uniform(-math.pi, math.pi)))

    def run(n: int) -> None:
        for k in range(n):
            env.sense(*poses[k % 512])

    return run


def batched_loop(size: int) -> Callable[[int], None]:
    """``env.step_and_maybe_reset`` with random actions fixed in advance; ``fn(n)`` makes
    ``n // size`` batch steps, i.e. about n robot-steps."""
    env = BatchedWorldEnv(size=size, seeds=list(range(size)))
    gen = torch.Generator().manual_seed(0)
    actions = (torch.rand(64, size, 1, generator=gen) * 2.0 - 1.0) * math.pi

    def run(n: int) -> None:
        td = env.reset()
        for k in range(max(n // size, 1)):
            td.set("action", actions[k % 64])
            _, td = env.step_and_maybe_reset(td)

    return run


def cartpole_loop() -> Callable[[int], None]:
    env = gymnasium.make("CartPole-v1").unwrapped

    def run(n: int) -> None:
        env.reset(seed=0)
        for k in range(n):
            _, _, terminated, truncated, _ = env.step(k & 1)
            if terminated or truncated:
                env.reset()

    return run


def numpy_loop() -> Callable[[int], None]:
    angles = np.linspace(0.0, 2 * math.pi, 24, endpoint=False)

    def run(n: int) -> None:
        for k in range(n):
            s = np.minimum(np.cos(angles + 0.001 * k), 0.5)
            _ = {"sonar": s.astype(np.float32)}

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="calls per measurement")
    parser.add_argument("--repeats", type=int, default=5, help="rounds; the best is kept")
    args = parser.parse_args()
    n, rep = args.steps, args.repeats

    cases: dict[str, Callable[[int], None]] = {
        "CartPole-v1 step (baseline)": cartpole_loop(),
        "numpy no-op step (baseline)": numpy_loop(),
        "Hailu2001Env.step, noise on, random actions": env_loop(Hailu2001Env(), "random"),
        "Hailu2001Env.step, noise on, goal-seeking actions": env_loop(Hailu2001Env(), "goal"),
        "Hailu2001Env.step, noise off, random actions": env_loop(
            Hailu2001Env(noise=False), "random"
        ),
        "sense only (sonar + IR, random free poses)": sense_loop(Hailu2001Env()),
        "sense only, 25 deg sonar cone (5 sub-rays)": sense_loop(
            Hailu2001Env(robot={"sonar_cone_deg": 25.0})
        ),
    }
    for size in (1, 10, 100):
        cases[f"BatchedWorldEnv B={size:<3d} robot-steps, noise on, random"] = batched_loop(size)
    rates = dict.fromkeys(cases, 0.0)
    for _ in range(rep):  # round robin, so every case sees the same mix of machine load
        for name, fn in cases.items():
            rates[name] = max(rates[name], timed(fn, n))
    cart = rates["CartPole-v1 step (baseline)"]
    noop = rates["numpy no-op step (baseline)"]
    print(f"{'what':52s} {'calls/cpu-s':>11s} {'us/call':>8s} {'x CartPole':>10s} {'x no-op':>8s}")
    for name, rate in rates.items():
        print(f"{name:52s} {rate:11.0f} {1e6 / rate:8.1f} {cart / rate:10.1f} {noop / rate:8.1f}")
    print("(x CartPole / x no-op: how many times slower than that baseline, same run;")
    print(" BatchedWorldEnv rows count robot-steps: B per env.step)")
    print(f"load_map of a 3,000-point boundary (validation): {map_validation(rep):.3f} CPU-s")


def map_validation(repeats: int) -> float:
    """CPU seconds to load and validate a map whose boundary has 3,000 points (best of
    ``repeats``): the map checks must stay well under a second for hand-made outlines."""
    from symrl.world.worldmap import load_map

    t = np.linspace(0.0, 2 * np.pi, 3000, endpoint=False)
    r = 10 + 0.5 * np.sin(7 * t)
    data = {
        "name": "wobbly",
        "boundary": np.round(np.stack([r * np.cos(t), r * np.sin(t)], 1), 6).tolist(),
        "start": {"x": 0.0, "y": 0.0},
        "goal": {"x": 3.0, "y": 0.0, "radius": 0.4},
        "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
    }
    best = math.inf
    for _ in range(repeats):
        t0 = time.process_time()
        load_map(data)
        best = min(best, time.process_time() - t0)
    return best


if __name__ == "__main__":
    main()
