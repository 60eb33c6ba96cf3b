"""Per-world numbers for docs/journal/maps.md: the reflex alone, `paper` and `paper_map` (hand
and found regions).

For every shipped world: the planner's optimum; ``reflex_only``; ``paper`` with the map's hand
regions; ``paper`` and ``paper_map`` with ``regions: auto`` (a copy of the map with its regions
removed). Each is one batched run of ``sets`` sets x ``trials`` trials, set k seeded
``seed + k`` (default 10 x 20, seeds 100-109). Prints the Markdown table: last-5-trial means over
sets (± sd), collisions, failed trials from trial 5 on (and from trial 10, in brackets) and
actions divided by the optimum.

    python docs/journal/scripts/map_results.py [--sets 10] [--trials 20] [--seed 100] [--maps a,b]
        [--variants reflex,hand,auto] [KEY=VALUE ...]

``--maps`` takes built-in names or paths of map files (e.g. the tuning worlds in
``symrl/world/maps/tuning/``); ``--variants`` picks the rows per world; ``KEY=VALUE`` overrides
apply to every run (``options.start_turn_deg=null``: ``paper`` without its start turn).
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
from symrl.world.worldmap import SUITES, builtin_maps, suite_maps

MAPS = (
    "hailu2001",
    "hailu2001_mirror",
    "two_doors",
    "two_door_room",
    "office",
    "l_corridor",
    "maze",
    "dead_end",
)


FAILED_FROM = 5
"""Trials from this one on count as failed if they miss the goal (the options have been tried
once each by then on the paper's world)."""
REACHED_FROM = 10
"""The target for the `check` and named worlds: every trial from this one reaches the goal (the
failed ones are counted again, in brackets)."""

VARIANTS = {
    "reflex": ("reflex alone", "reflex_only"),
    "rules": ("`paper` (regions rung), hand regions", "paper"),
    "rules_auto": ("`paper` (regions rung), `regions: auto`", "paper"),
    "passages": ("`paper_passages` (passages rung), hand regions", "paper_passages"),
    "hand": ("`paper_map`, hand regions", "paper_map"),
    "auto": ("`paper_map`, `regions: auto`", "paper_map"),
}


def auto_copy(name: str, folder: Path) -> Path:
    """The map (a built-in name or a file) as a file with its hand regions removed (regions
    found from the walls)."""
    world = load_map(name)
    doc = yaml.safe_load(Path(world.source).read_text())
    doc.pop("regions", None)
    doc["name"] = f"{world.name}_auto"
    path = folder / f"{world.name}_auto.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def row(world: str, variant: str, rows: list[dict], opt: dict, wall: float) -> str:
    s = summarise(rows)
    by_set: dict[int, list[dict]] = {}
    for r in rows:
        by_set.setdefault(int(r["set"]), []).append(r)
    tail_coll = np.mean(
        [
            np.mean([float(r["collisions"]) for r in sorted(v, key=lambda r: r["trial"])[-LAST:]])
            for v in by_set.values()
        ]
    )
    st, tr, co = (
        s[f"steps_last{LAST}"],
        s[f"total_reinforcement_last{LAST}"],
        s["collisions_all_trials"],
    )
    late = [r for r in rows if int(r["trial"]) >= FAILED_FROM]  # the target: none fails
    failed = sum(not bool(r["reached_goal"]) for r in late)
    later = sum(not bool(r["reached_goal"]) for r in late if int(r["trial"]) >= REACHED_FROM)
    return (
        f"| `{world}` | {variant} | {opt['steps']} | {s[f'success_last{LAST}']:.0%} "
        f"| {st['mean']:.1f} ± {st['std']:.1f} | {tr['mean']:.2f} ± {tr['std']:.2f} "
        f"| {tail_coll:.2f} | {co['mean']:.1f} | {failed} of {len(late)} ({later}) "
        f"| {st['mean'] / opt['steps']:.2f} | {wall:.0f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--maps", default=",".join(MAPS), help="built-in names or map file paths")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="of reflex, hand, auto")
    ap.add_argument(
        "overrides",
        nargs="*",
        metavar="KEY=VALUE",
        help="config overrides for every run (as after a recipe: options.reach=0.3)",
    )
    args = ap.parse_args()
    maps = [m.strip() for m in args.maps.split(",") if m.strip()]
    shipped = builtin_maps() + [n for s in SUITES for n in suite_maps(s)]
    unknown = sorted(m for m in maps if m not in shipped and not Path(m).is_file())
    if unknown:
        raise SystemExit(f"unknown map(s) {unknown}: not a file; built-in: {builtin_maps()}")
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    if set(variants) - set(VARIANTS):
        raise SystemExit(f"unknown variant(s) {sorted(set(variants) - set(VARIANTS))}")
    lines = [
        f"| world | controller | optimum actions | success last {LAST} "
        f"| actions last {LAST} | total reinf. last {LAST} | collisions per trial last {LAST} "
        f"| collisions all trials | failed trials from trial {FAILED_FROM} (from {REACHED_FROM}) "
        "| actions / optimum "
        "| wall time (s) |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for name in maps:
            opt = optimum(name)
            title = load_map(name).name
            for variant in variants:
                label, recipe = VARIANTS[variant]
                auto = variant in ("auto", "rules_auto")
                world = str(auto_copy(name, Path(tmp))) if auto else name
                t0 = time.perf_counter()
                overrides = [f"env.map={world}", *args.overrides]
                sets = run_sets(
                    recipe, args.sets, args.trials, args.seed, overrides, progress=False
                )
                rows = [r for s in sets for r in s.rows]
                lines.append(row(title, label, rows, opt, time.perf_counter() - t0))
                print(lines[-1], flush=True)
    print()
    print(
        f"{args.sets} sets x {args.trials} trials, seeds {args.seed}-"
        f"{args.seed + args.sets - 1}, noise on"
    )
    print("\n".join(lines))


if __name__ == "__main__":
    main()
