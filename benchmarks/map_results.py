"""Per-world numbers for docs/MAPS.md: the reflex alone and `paper` (hand and found regions).

For every shipped world: the planner's optimum; ``reflex_only``; ``paper`` with the map's hand
regions; ``paper`` with ``regions: auto`` (a copy of the map with its regions removed). Each is
one batched run of ``sets`` sets x ``trials`` trials, set k seeded ``seed + k`` (default 10 x 20,
seeds 100-109). Prints the Markdown table: last-5-trial means over sets (± sd), collisions and
actions divided by the optimum.

    python benchmarks/map_results.py [--sets 10] [--trials 20] [--seed 100] [--maps a,b]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from symrl.studies.runner import LAST, optimum, run_sets, summarise
from symrl.world import load_map
from symrl.world.worldmap import builtin_maps

MAPS = (
    "hailu2001", "hailu2001_mirror", "two_doors", "two_door_room", "office", "l_corridor", "maze",
    "dead_end",
)


def auto_copy(name: str, folder: Path) -> Path:
    """The map as a file with its hand regions removed (regions found from the walls)."""
    world = load_map(name)
    doc = yaml.safe_load(Path(world.source).read_text())
    doc.pop("regions", None)
    doc["name"] = f"{name}_auto"
    path = folder / f"{name}_auto.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def row(world: str, variant: str, rows: list[dict], opt: dict, wall: float) -> str:
    s = summarise(rows)
    by_set: dict[int, list[dict]] = {}
    for r in rows:
        by_set.setdefault(int(r["set"]), []).append(r)
    tail_coll = np.mean(
        [np.mean([float(r["collisions"]) for r in sorted(v, key=lambda r: r["trial"])[-LAST:]])
         for v in by_set.values()]
    )
    st, tr, co = s[f"steps_last{LAST}"], s[f"total_reinforcement_last{LAST}"], \
        s["collisions_all_trials"]
    return (
        f"| `{world}` | {variant} | {opt['steps']} | {s[f'success_last{LAST}']:.0%} "
        f"| {st['mean']:.1f} ± {st['std']:.1f} | {tr['mean']:.2f} ± {tr['std']:.2f} "
        f"| {tail_coll:.2f} | {co['mean']:.1f} | {st['mean'] / opt['steps']:.2f} | {wall:.0f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--maps", default=",".join(MAPS))
    args = ap.parse_args()
    maps = [m.strip() for m in args.maps.split(",") if m.strip()]
    unknown = sorted(set(maps) - set(builtin_maps()))
    if unknown:
        raise SystemExit(f"unknown map(s) {unknown}; built-in: {builtin_maps()}")
    lines = [
        f"| world | controller | optimum actions | success last {LAST} "
        f"| actions last {LAST} | total reinf. last {LAST} | collisions per trial last {LAST} "
        "| collisions all trials | actions / optimum | wall time (s) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for name in maps:
            opt = optimum(name)
            variants = [
                ("reflex alone", "reflex_only", name),
                ("`paper`, hand regions", "paper", name),
                ("`paper`, `regions: auto`", "paper", str(auto_copy(name, Path(tmp)))),
            ]
            for label, recipe, world in variants:
                t0 = time.perf_counter()
                sets = run_sets(recipe, args.sets, args.trials, args.seed, [f"env.map={world}"],
                                progress=False)  # fmt: skip
                rows = [r for s in sets for r in s.rows]
                lines.append(row(name, label, rows, opt, time.perf_counter() - t0))
                print(lines[-1], flush=True)
    print()
    print(f"{args.sets} sets x {args.trials} trials, seeds {args.seed}-"
          f"{args.seed + args.sets - 1}, noise on")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
