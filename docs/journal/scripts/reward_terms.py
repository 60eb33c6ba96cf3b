"""The reward's two terms over a recipe's last 5 trials: f1 (the sonar's wall proximity, -3 on a
collision) and f2 (the heading's error to the goal), summed per trial and averaged over sets.

Each set is one robot of a batched run (``recipe``, 20 trials, set k seeded ``seed + k``); the
terms are read from the simulator's per-step readings, which the env's TensorDict does not carry.
Used to find which term moved when ``paper_map``'s route option replaced its route rules.

    python docs/journal/scripts/reward_terms.py RECIPE [--seed 6000] [--sets 40] [KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import statistics
from typing import Any

import numpy as np

from symrl.learner.config import load_config
from symrl.train import train_batch
from symrl.world import physics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recipe")
    parser.add_argument("--seed", type=int, default=6000)
    parser.add_argument("--sets", type=int, default=40)
    parser.add_argument("overrides", nargs="*")
    args = parser.parse_args()
    sums = {name: np.zeros(args.sets) for name in ("f1", "f2", "near")}
    step = physics.RobotBatch.step

    def counted(self: Any, alpha: Any, rngs: Any) -> Any:
        r = step(self, alpha, rngs)
        sums["f1"] += r.f1
        sums["f2"] += r.f2
        sums["near"] += r.f1 < 0
        return r

    physics.RobotBatch.step = counted  # type: ignore[method-assign]
    trials: dict[int, list[tuple[float, ...]]] = {b: [] for b in range(args.sets)}

    def on_trial(b: int, record: dict[str, Any], policy: Any) -> None:
        trials[b].append(
            (
                record["total_reinforcement"],
                sums["f1"][b],
                sums["f2"][b],
                sums["near"][b],
                record["steps"],
            )
        )
        for value in sums.values():
            value[b] = 0.0

    config = load_config(args.recipe, ["run.trials=20", *args.overrides])
    seeds = [args.seed + k for k in range(args.sets)]
    train_batch(config, seeds, progress=False, on_trial=on_trial)
    last = [row for rows in trials.values() for row in rows[-5:]]
    total, f1, f2, near, actions = (statistics.mean(column) for column in zip(*last, strict=True))
    print(
        f"{args.recipe}, seeds {seeds[0]}-{seeds[-1]}, last 5 trials: total {total:.3f} = "
        f"f1 {f1:.3f} + f2 {f2:.3f}; actions {actions:.2f}, of them near a wall {near:.2f}"
    )


if __name__ == "__main__":
    main()
