"""The README's opening picture: the reflex's path beside the path `paper` learned (seed 100).

python docs/scripts/readme_figure.py [--out docs/figures/readme.png]
"""

from __future__ import annotations

import argparse

from symrl.figures import plot_paths
from symrl.learner.config import load_config
from symrl.train import train


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/figures/readme.png")
    parser.add_argument("--seed", type=int, default=100)
    args = parser.parse_args()
    reflex = train(
        load_config("reflex_only", ["run.trials=1", f"run.seed={args.seed}"]), progress=False
    ).trials[0]
    learned = train(
        load_config("paper", ["run.trials=20", f"run.seed={args.seed}"]), progress=False
    )
    last = learned.trials[-1]
    plot_paths(
        learned.world,
        [
            (
                f"the fuzzy reflex alone: {reflex['steps']} actions, "
                f"total {reflex['total_reinforcement']:.1f}",
                [reflex["path"]],
                [],
            ),
            (
                f"paper (told the region rules), trial {last['trial']}: {last['steps']} actions, "
                f"total {last['total_reinforcement']:.1f}",
                [last["path"]],
                [],
            ),
        ],
        args.out,
        columns=2,
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
