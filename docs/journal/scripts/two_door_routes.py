"""Which door the learned routes of ``two_door_room`` take: the upper one, on the goal's bearing
(30 actions at best), or the lower one, off it (27).

``paper`` with the map's hand regions and with ``regions: auto``, ``sets`` x 20 trials, set k
seeded ``seed + k``; each set's last 5 trials are sorted by where their path last crosses the
dividing wall (x = 3.625; above y = -0.875 is the upper door) and their mean actions printed.

    python docs/journal/scripts/two_door_routes.py [--sets 10] [--seed 0]
"""

from __future__ import annotations

import argparse
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch

from symrl.studies.runner import resolve_config
from symrl.train import train_batch

WALL_X, DOOR_SPLIT_Y = 3.625, -0.875


def door(path: np.ndarray) -> str:
    a, b = path[:-1], path[1:]
    crossings = np.flatnonzero((a[:, 0] < WALL_X) & (b[:, 0] >= WALL_X))
    if len(crossings) == 0:
        return "none"
    k = crossings[-1]
    y = a[k, 1] + (WALL_X - a[k, 0]) * (b[k, 1] - a[k, 1]) / (b[k, 0] - a[k, 0])
    return "upper" if y > DOOR_SPLIT_Y else "lower"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    torch.set_num_threads(1)
    from map_results import auto_copy  # the same auto-region copy as the per-world table

    with tempfile.TemporaryDirectory() as tmp:
        auto = str(auto_copy("two_door_room", Path(tmp)))
        for label, world in (("hand regions", "two_door_room"), ("regions: auto", auto)):
            config = resolve_config("paper_map", [f"env.map={world}", "run.trials=20"])
            results = train_batch(
                config, list(range(args.seed, args.seed + args.sets)), progress=False
            )
            steps: dict[str, list[int]] = defaultdict(list)
            for r in results:
                for t in r.trials[-5:]:
                    steps[door(np.asarray(t["path"]))].append(int(t["steps"]))
            summary = ", ".join(
                f"{d} door {len(v)} trials, {np.mean(v):.1f} actions"
                for d, v in sorted(steps.items())
            )
            print(f"two_door_room, {label}, last 5 trials of {args.sets} sets: {summary}")


if __name__ == "__main__":
    main()
