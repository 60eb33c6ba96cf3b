"""How well does the fuzzy reflex alone drive? (the numbers docs/explanation/algorithm.md
section 4 reports)

From the map's start: 20 seeds with noise on, and once with noise off: success rate, mean
actions, total reinforcement and collisions. Then the success rate from random free start
poses (uniform position with at least 0.1 m of clearance beyond the body, uniform heading),
once without noise and once with noise (seed = pose index).

    python docs/journal/scripts/reflex_coverage.py [--seeds 20] [--poses 150] [--pose-seed S]
        [--out FILE]

Reference (docs/explanation/algorithm.md): 20/20 from the start in ~37 actions, total ~-16,
~0.7 collisions; 32 actions without noise; 150/150 from random free poses.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path

import numpy as np

from symrl.drive import drive
from symrl.knowledge.reflex import ReflexConfig
from symrl.world.env import Hailu2001Env
from symrl.world.worldmap import load_map


def random_free_poses(n: int, seed: int, map_name: str = "hailu2001", margin: float = 0.1):
    """``n`` poses uniform over the free area, at least ``radius + margin`` from every wall,
    not already inside the goal circle, heading uniform in [-pi, pi)."""
    world = load_map(map_name)
    env = Hailu2001Env(map=world, noise=False)
    rng = np.random.default_rng(seed)
    xmin, xmax, ymin, ymax = world.bounds
    need = env.robot.radius + margin
    g = world.goal
    poses: list[tuple[float, float, float]] = []
    while len(poses) < n:
        x, y = rng.uniform(xmin, xmax), rng.uniform(ymin, ymax)
        if not world.in_free_area(x, y) or env.clearance(x, y) < need:
            continue
        if math.hypot(x - g.x, y - g.y) <= g.radius + 0.2:
            continue
        poses.append((float(x), float(y), float(rng.uniform(-math.pi, math.pi))))
    return poses


def describe(trials: list[dict]) -> str:
    ok = [t for t in trials if t["reached_goal"]]
    line = f"success {len(ok)}/{len(trials)}"
    if ok:
        steps = [t["steps"] for t in ok]
        totals = [t["total_reinforcement"] for t in ok]
        coll = [t["collisions"] for t in ok]
        sd = statistics.stdev(totals) if len(totals) > 1 else 0.0
        line += (
            f" | actions mean {statistics.mean(steps):.1f} (min {min(steps)}, max {max(steps)})"
            f" | total r mean {statistics.mean(totals):.2f} (sd {sd:.2f})"
            f" | collisions mean {statistics.mean(coll):.2f}"
        )
    return line


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="noisy trials from the start")
    parser.add_argument("--poses", type=int, default=150, help="random free start poses")
    parser.add_argument("--pose-seed", type=int, default=12345, help="seed of the pose sampler")
    parser.add_argument("--out", default=None, help="write all numbers as JSON here")
    args = parser.parse_args()

    t0 = time.perf_counter()
    rc = ReflexConfig()
    noisy = [drive(seed=s, noise=True, reflex_config=rc) for s in range(args.seeds)]
    clean = drive(seed=0, noise=False, reflex_config=rc)
    print(f"from the start, noise on, seeds 0..{args.seeds - 1}: {describe(noisy)}")
    print(f"from the start, noise off: {describe([clean])}")

    poses = random_free_poses(args.poses, args.pose_seed)
    from_poses: dict[str, list[dict]] = {}
    for noise in (False, True):
        trials = [
            drive(start=p, seed=i, noise=noise, reflex_config=rc) for i, p in enumerate(poses)
        ]
        from_poses["noise_on" if noise else "noise_off"] = trials
        slow = sum(t["steps"] > 100 for t in trials)
        print(
            f"from {len(poses)} random free poses, noise {'on' if noise else 'off'}: "
            f"{describe(trials)} | over 100 actions: {slow}"
        )
        for (x, y, h), t in zip(poses, trials, strict=True):
            if not t["reached_goal"]:
                print(f"  failed from ({x:.2f}, {y:.2f}, {h:.2f}), {t['collisions']} collisions")
    print(f"wall time {time.perf_counter() - t0:.1f} s")

    if args.out:
        keep = ("steps", "collisions", "total_reinforcement", "reached_goal", "start", "seed")
        data = {
            "noise_on": [{k: t[k] for k in keep} for t in noisy],
            "noise_off": {k: clean[k] for k in keep},
            "random_poses": {
                name: [{k: t[k] for k in keep} for t in trials]
                for name, trials in from_poses.items()
            },
        }
        Path(args.out).write_text(json.dumps(data, indent=1))


if __name__ == "__main__":
    main()
