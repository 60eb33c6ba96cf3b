"""What each learned part of `paper` buys, as on - off on the same sets: the crossing map, the
remembered way, the option critic, the experts, and all of them.

For every world: `paper`, then `paper` with one learned part off, each one batched run of
``sets`` sets x ``trials`` trials (set k seeded ``seed + k``). Prints a Markdown table: the last
5 trials' total reinforcement and actions over the planner's optimum, and the paired difference
full - off over the sets (mean ± standard error; positive: the part helps).

    python docs/journal/scripts/learned_shares.py [--maps hailu2001,office] [--sets 10]
        [--trials 20] [--seed 9000]

Off means: the crossing map ``crossings.enabled=false`` (each border option aims at one fixed
point; the remembered way, which steers over the crossings, goes with it); the remembered way
``options.remembered_way=false``; the option critic ``option_critic.epsilon=0
option_critic.try_untried=false`` (it never explores: every region keeps its first option until
a timeout); the experts
``experts.learning=false`` (the reflex's actions, no residual corrections, no trial gradient).
"""

from __future__ import annotations

import argparse

import numpy as np

from symrl.studies.runner import LAST, curves, optimum, run_sets

VARIANTS = {
    "paper": [],
    # the remembered way steers over the crossings: it goes with them
    "crossing map off": ["crossings.enabled=false", "options.remembered_way=false"],
    "remembered way off": ["options.remembered_way=false"],
    "option critic off": ["option_critic.epsilon=0", "option_critic.try_untried=false"],
    "experts off": ["experts.learning=false"],
    "all off": [
        "crossings.enabled=false",
        "options.remembered_way=false",
        "option_critic.epsilon=0",
        "option_critic.try_untried=false",
        "experts.learning=false",
    ],
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="hailu2001,office,maze,two_doors")
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seed", type=int, default=9000)
    args = ap.parse_args()
    lines = [
        f"| world | variant | total last {LAST} | full - off (paired) | actions / optimum |",
        "| --- | --- | ---: | ---: | ---: |",
    ]
    for world in [m.strip() for m in args.maps.split(",") if m.strip()]:
        best = optimum(world)["steps"]
        full = None
        for name, overrides in VARIANTS.items():
            sets = run_sets(
                "paper",
                args.sets,
                args.trials,
                args.seed,
                [f"env.map={world}", *overrides],
                progress=False,
            )
            rows = [r for s in sets for r in s.rows]
            total = curves(rows, "total_reinforcement")[:, -LAST:].mean(axis=1)  # per set
            steps = curves(rows, "steps")[:, -LAST:].mean()
            if full is None:
                full, delta = total, ""
            else:
                d = full - total
                delta = f"{d.mean():+.2f} ± {d.std(ddof=1) / np.sqrt(len(d)):.2f}"
            lines.append(
                f"| `{world}` | {name} | {total.mean():.2f} | {delta} | {steps / best:.2f} |"
            )
            print(lines[-1], flush=True)
    print()
    print(
        f"{args.sets} sets x {args.trials} trials, seeds {args.seed}-"
        f"{args.seed + args.sets - 1}, noise on"
    )
    print("\n".join(lines))


if __name__ == "__main__":
    main()
