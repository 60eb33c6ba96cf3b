"""How fast is the scan odometry? B robots' fits in one batched call against one robot at a time.

``ScanOdometry`` (``symrl/knowledge/scan_odometry.py``) fits each robot's scan to its own
keyframe's echoes. Called with the whole batch it makes one fit for every robot (their echoes
rows of a ``WallSets``); called with one robot at a time (B trackers of one robot each) it makes
B fits, as the code did before the fits were batched. Both are fed the same recorded
observations: B robots driving trial-like paths (turning toward the goal with some jitter,
reset at a trial's end) in a world of their own seed. The beliefs must be the same to the bit;
the figure is robot-steps per CPU second (``time.process_time``), best of ``--rounds``
interleaved rounds, and the ratio of the two in the same run.

    python benchmarks/bench_scan_odometry.py [--map tuning/t_wrong_arm] [--sizes 1,10]
        [--steps 400] [--rounds 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from symrl.knowledge.scan_odometry import ScanOdometry
from symrl.world.env import Hailu2001Env


def record(world: str, size: int, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``steps`` observations of ``size`` robots (robot k's world seeded k): odometry (T, B, 3),
    sonar (T, B, n), and which robots start a trial at each step (T, B) bool."""
    odometry, sonar, fresh = [], [], []
    for k in range(size):
        env = Hailu2001Env(map=world)
        rng = np.random.default_rng(k)
        obs, _ = env.reset(seed=k)
        rows: list[tuple[np.ndarray, np.ndarray, bool]] = [(obs["odometry"], obs["sonar"], True)]
        for _ in range(steps - 1):
            action = obs["goal"][1] + 0.3 * rng.uniform(-1.0, 1.0)
            obs, _, terminated, truncated, _ = env.step(np.array([action], dtype=np.float32))
            done = terminated or truncated
            if done:
                obs, _ = env.reset()
            rows.append((obs["odometry"], obs["sonar"], done))
        odometry.append(np.stack([r[0] for r in rows]))
        sonar.append(np.stack([r[1] for r in rows]))
        fresh.append(np.array([r[2] for r in rows]))
    return np.stack(odometry, 1), np.stack(sonar, 1), np.stack(fresh, 1)


def batched(odometry: np.ndarray, sonar: np.ndarray, fresh: np.ndarray) -> np.ndarray:
    """Every step's beliefs (T, B, 3) from one tracker of the whole batch."""
    tracker = ScanOdometry(Hailu2001Env().robot, odometry.shape[1])
    out = np.empty(odometry.shape, dtype=np.float64)
    for t in range(len(odometry)):
        starting = np.flatnonzero(fresh[t])
        if len(starting):
            tracker.begin_trial(starting)
        out[t] = tracker(odometry[t], sonar[t])
    return out


def one_at_a_time(odometry: np.ndarray, sonar: np.ndarray, fresh: np.ndarray) -> np.ndarray:
    """The same from B trackers of one robot each, called in turn (B fits a step)."""
    robot = Hailu2001Env().robot
    trackers = [ScanOdometry(robot, 1) for _ in range(odometry.shape[1])]
    out = np.empty(odometry.shape, dtype=np.float64)
    for t in range(len(odometry)):
        for b, tracker in enumerate(trackers):
            if fresh[t, b]:
                tracker.begin_trial(np.array([0]))
            out[t, b] = tracker(odometry[t, b : b + 1], sonar[t, b : b + 1])[0]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--map", default="tuning/t_wrong_arm")
    parser.add_argument("--sizes", default="1,10", help="batch sizes, comma-separated")
    parser.add_argument("--steps", type=int, default=400, help="observations per robot")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"ScanOdometry on {args.map}, {args.steps} observations a robot; robot-steps per CPU")
    print(f"second, best of {args.rounds} rounds")
    print("| B | batched | one robot at a time | ratio | same beliefs |")
    print("| ---: | ---: | ---: | ---: | --- |")
    for size in sizes:
        observations = record(args.map, size, args.steps)
        best = {"batched": 0.0, "one": 0.0}
        same = True
        for _ in range(args.rounds):
            results = {}
            for name, run in (("batched", batched), ("one", one_at_a_time)):
                t0 = time.process_time()
                results[name] = run(*observations)
                rate = args.steps * size / max(time.process_time() - t0, 1e-9)
                best[name] = max(best[name], rate)
            same &= bool(np.array_equal(results["batched"], results["one"]))
        ratio = best["batched"] / best["one"] if best["one"] > 0 else math.nan
        print(
            f"| {size} | {best['batched']:,.0f} | {best['one']:,.0f} | {ratio:.2f} | "
            f"{'yes' if same else 'NO'} |"
        )


if __name__ == "__main__":
    main()
