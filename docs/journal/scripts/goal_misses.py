"""Why a learned controller misses the goal in a last trial: where the failed trials end, with the
robot's odometry as shipped and with perfect odometry, and how far odometry drifts along a path.

For each map: ``paper`` (hand regions), ``sets`` x 20 trials, set k seeded ``seed + k``; every
failed trial among each set's last 5 is counted by the region it ends in (and, in the goal's
region, its distance to the goal). Then the same with ``env.robot.perfect_odometry=true`` (the
same motion noise; the odometry pose is the true one). Last, the reflex alone driven ``drives``
times per map (seeds ``seed``...): the distance between its true and its odometry end point.

    python docs/journal/scripts/goal_misses.py [--maps maze,office] [--sets 10] [--seed 0]
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
import torch

from symrl.drive import drive
from symrl.studies.runner import resolve_config
from symrl.train import train_batch

PERFECT = "env.robot.perfect_odometry=true"


def misses(name: str, sets: int, seed: int, overrides: list[str]) -> Counter:
    config = resolve_config("paper_map", [f"env.map={name}", "run.trials=20", *overrides])
    results = train_batch(config, list(range(seed, seed + sets)), progress=False)
    world = results[0].world
    goal = np.array([world.goal.x, world.goal.y])
    home = world.regions.region_of(*goal)
    out: Counter = Counter()
    for r in results:
        for t in r.trials[-5:]:
            if t["reached_goal"]:
                out["reached"] += 1
                continue
            end = np.asarray(t["path"])[-1]
            region = world.regions.region_of(*end)
            far = f", {np.hypot(*(end - goal)):.1f} m from the goal" if region == home else ""
            out[f"missed, ends in {region}{far}"] += 1
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maze,office")
    ap.add_argument("--drift-maps", default="hailu2001,l_corridor")
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--drives", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    torch.set_num_threads(1)
    for name in args.maps.split(","):
        variants = (("odometry as shipped", []), ("perfect odometry", [PERFECT]))
        for label, extra in variants:
            print(
                f"{name}, {label}: last 5 trials of {args.sets} sets:",
                dict(misses(name, args.sets, args.seed, extra)),
                flush=True,
            )
    for name in args.drift_maps.split(","):
        errors, lengths = [], []
        for s in range(args.seed, args.seed + args.drives):
            r = drive(map=name, noise=True, seed=s)
            true, odo = np.asarray(r["path"])[-1], np.asarray(r["odometry_path"])[-1]
            errors.append(float(np.hypot(*(true - odo))))
            lengths.append(r["path_length"])
        e = np.array(errors)
        print(
            f"{name}, reflex alone, {args.drives} drives: path {np.mean(lengths):.1f} m, "
            f"odometry error at the end {e.mean():.2f} m mean, {e.max():.2f} m max, "
            f"above 0.4 m in {(e > 0.4).sum()}"
        )


if __name__ == "__main__":
    main()
