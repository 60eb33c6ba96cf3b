"""The remembered ways of one robot of `paper` after its trials, one per option of the region its
trials start in (``options.way_per_start_option``), drawn over the world's walls (read from the
map for the figure only: the robot never sees them).

Each way is drawn from where its best trial began, through its via-points, to the goal, in the
robot's odometry, and labelled with the start option it belongs to and its best trial's actions.

    python docs/journal/scripts/start_ways.py [--map tuning/near_door_long_way] [--seed 5000]
        [--trials 20] [--out docs/figures/start-ways.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from symrl.figures.parts import draw_map  # noqa: E402
from symrl.studies.runner import resolve_config  # noqa: E402
from symrl.train import train_batch  # noqa: E402

NO_WAY = 1 << 30


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", default="tuning/near_door_long_way")
    ap.add_argument("--seed", type=int, default=5000)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--out", type=Path, default=Path("docs/figures/start-ways.png"))
    args = ap.parse_args()
    config = resolve_config("paper", [f"env.map={args.map}", f"run.trials={args.trials}"])
    (result,) = train_batch(config, [args.seed], progress=False)
    options = result.policy.options
    way = options.remembered_way
    world = result.world
    start = world.regions.region_of(world.start.x, world.start.y)
    labels = options.labels[list(options.region_names).index(start)]
    fig, ax = plt.subplots(figsize=(6.0, 5.2), dpi=120)
    draw_map(ax, world)
    for k, label in enumerate(labels):
        best = int(way.best[0, k])
        if best >= NO_WAY:
            continue
        n = int(way.count[0, k])
        line = np.vstack((way.origin[0, k], way.points[0, k, :n], np.array(options.goal)))
        ax.plot(*line.T, "-o", ms=3, lw=2, label=f"start option {label!r}: best {best} actions")
    steps = [int(t["steps"]) for t in result.trials]
    ax.set_title(
        f"{args.map}, seed {args.seed}: the ways after {len(steps)} trials "
        f"(last 5: {np.mean(steps[-5:]):.1f} actions)",
        fontsize=9,
    )
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(f"wrote {args.out}; trials {steps}")


if __name__ == "__main__":
    main()
