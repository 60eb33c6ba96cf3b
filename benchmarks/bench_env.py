"""How fast is the world? Raw `Hailu2001Env.step` (noise on), sensing alone, and baselines.

The machine is shared, so absolute numbers drift; every figure is also printed as a ratio to
baselines measured in the same run (gymnasium's CartPole-v1 step and a trivial numpy step).

    python benchmarks/bench_env.py [--steps 20000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import gymnasium
import numpy as np

from symrl.world.env import Hailu2001Env


def best_rate(fn: Callable[[int], None], n: int, repeats: int) -> float:
    """Calls per second of ``fn(n)`` (which makes n calls), best of ``repeats``."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(n)
        best = min(best, time.perf_counter() - t0)
    return n / best


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
    parser.add_argument("--steps", type=int, default=20000, help="calls per measurement")
    parser.add_argument("--repeats", type=int, default=3, help="best of this many")
    args = parser.parse_args()
    n, rep = args.steps, args.repeats

    rates = {
        "CartPole-v1 step (baseline)": best_rate(cartpole_loop(), n, rep),
        "numpy no-op step (baseline)": best_rate(numpy_loop(), n, rep),
        "Hailu2001Env.step, noise on, random actions": best_rate(
            env_loop(Hailu2001Env(), "random"), n, rep
        ),
        "Hailu2001Env.step, noise on, goal-seeking actions": best_rate(
            env_loop(Hailu2001Env(), "goal"), n, rep
        ),
        "Hailu2001Env.step, noise off, random actions": best_rate(
            env_loop(Hailu2001Env(noise=False), "random"), n, rep
        ),
        "sense only (sonar + IR, random free poses)": best_rate(sense_loop(Hailu2001Env()), n, rep),
        "sense only, 25 deg sonar cone (5 sub-rays)": best_rate(
            sense_loop(Hailu2001Env(robot={"sonar_cone_deg": 25.0})), n, rep
        ),
    }
    cart = rates["CartPole-v1 step (baseline)"]
    noop = rates["numpy no-op step (baseline)"]
    print(f"{'what':52s} {'calls/s':>10s} {'us/call':>8s} {'x CartPole':>10s} {'x no-op':>8s}")
    for name, rate in rates.items():
        print(f"{name:52s} {rate:10.0f} {1e6 / rate:8.1f} {cart / rate:10.1f} {noop / rate:8.1f}")
    print("(x CartPole / x no-op: how many times slower than that baseline, same run)")


if __name__ == "__main__":
    main()
