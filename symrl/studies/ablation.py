"""`symrl ablate`: the repeatability study for every recipe, with the same seeds, side by side.

Which part of the prior knowledge matters? Every recipe runs the same sets (seed + k)
and trials; all (recipe, set) runs share one worker pool. The folder gets one sub-folder per
recipe (as `symrl study` writes it), ``summary.md`` / ``summary.json`` and ``comparison.png``.

Summary columns (mean ± std over sets unless said):
- first success: the first trial that reached the goal (sets that never did are counted apart)
- success last 5: fraction of the last 5 trials (all sets pooled) that reached the goal
- steps / total reinforcement last 5: per set the mean over its last 5 trials (a failed trial
  counts with its 200 actions), then mean ± std over sets
- neurons / collisions last trial, and collisions summed over all trials of a set
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from symrl.runs import read_trials_csv
from symrl.studies.repeatability import (
    PAPER_TABLE1,
    StudyResult,
    write_study,
)
from symrl.studies.runner import (
    LAST,
    curves,
    optimum,
    run_sets,
    start_summary,
    summarise,
    table1,
)

__all__ = ["RECIPES", "summarise", "summary_markdown", "run_ablation", "ablate_command"]

RECIPES = ("paper", "paper_literal", "no_partition", "no_reflex", "plain", "reflex_only")

def _pm(d: dict[str, float], fmt: str = ".1f") -> str:
    if not np.isfinite(d["mean"]):
        return "-"
    return f"{d['mean']:{fmt}} ± {d['std']:{fmt}}"


def summary_markdown(summary: dict[str, dict[str, Any]], last: int = LAST) -> str:
    """One row per recipe; the paper's last-trial numbers and the optimum as reference rows."""
    lines = [
        f"| recipe | sets × trials | first success (never) | success last {last} "
        f"| steps last {last} | total reinf. last {last} | neurons last | collisions last "
        "| collisions all trials |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for recipe, s in summary.items():
        if recipe.startswith("_"):
            continue
        fs = s["first_success"]
        first = f"{_pm(fs)} ({fs['never']})"
        lines.append(
            f"| {recipe} | {s['sets']} × {s['trials']} | {first} | {s[f'success_last{last}']:.0%} "
            f"| {_pm(s[f'steps_last{last}'])} | {_pm(s[f'total_reinforcement_last{last}'], '.2f')} "
            f"| {_pm(s['neurons_last'])} | {_pm(s['collisions_last'], '.2f')} "
            f"| {_pm(s['collisions_all_trials'])} |"
        )
    p = PAPER_TABLE1
    if summary.get("_map", "hailu2001") == "hailu2001":  # the paper's numbers: its world only
        lines.append(
            f"| *paper, Table 1 (last trial)* | 10 × 20 | - | - | {p['steps']['mean']} "
            f"(var {p['steps']['variance']}) | {p['total_reinforcement']['mean']} "
            f"(var {p['total_reinforcement']['variance']}) | {p['neurons']['mean']} "
            f"(var {p['neurons']['variance']}) | - | - |"
        )
    opt = summary.get("_optimum")
    if opt:
        lines.append(f"| *optimum (`symrl plan`)* | - | - | - | {opt['steps']} | - | - | 0 | 0 |")
    return "\n".join(lines) + "\n"


def run_ablation(
    recipes: Sequence[str] = RECIPES,
    sets: int = 10,
    trials: int = 20,
    seed: int = 100,
    workers: int | None = 1,
    out: Path | str | None = "results/ablate",
    figures: bool = True,
    starts: Sequence[tuple[float, float, float]] | None = None,
    map: str = "hailu2001",
) -> dict[str, Any]:
    """Run every recipe's study on the same seeds in ``map`` (name or file; each recipe trained
    with ``env.map=map``); return (and write) the summary. ``starts``: where the final
    controllers are also driven from (default: the paper's four on its world, the map's own or
    derived poses elsewhere, ``symrl.studies.placement.study_starts``)."""
    if sets < 1 or trials < 1:
        raise ValueError(f"need at least 1 set and 1 trial, got sets={sets}, trials={trials}")
    if not recipes:
        raise ValueError("run_ablation: no recipes given")
    from symrl.about import provenance
    from symrl.studies.placement import study_starts
    from symrl.world import load_map

    t0 = time.perf_counter()
    code = provenance()
    world = load_map(map)
    if starts is None:
        starts = study_starts(world)
    opt = optimum(map)
    summary: dict[str, Any] = {}
    studies: dict[str, StudyResult] = {}
    for recipe in recipes:
        r0 = time.perf_counter()
        sets_r = run_sets(recipe, sets, trials, seed, [f"env.map={map}"], starts, workers)
        rows = [r for s in sets_r for r in s.rows]
        table = table1(rows)
        table.update(optimum=opt, recipe=recipe, seeds=[seed, seed + sets - 1])
        if world.name == "hailu2001":  # the paper's numbers are of its world only
            table["paper"] = PAPER_TABLE1
        table["other_starts"] = start_summary(sets_r)
        table["provenance"] = code
        wall_r = time.perf_counter() - r0
        table["wall_time_s"] = round(wall_r, 1)
        table["map"] = world.name
        study = StudyResult(recipe, sets_r, table, Path(out) / recipe if out else None, wall_r,
                            world)  # fmt: skip
        studies[recipe] = study
        summary[recipe] = summarise(rows)
        summary[recipe]["wall_time_s"] = round(wall_r, 1)
    wall = time.perf_counter() - t0
    summary["_optimum"] = opt
    summary["_map"] = world.name
    summary["_seeds"] = [seed, seed + sets - 1]
    summary["_wall_time_s"] = round(wall, 1)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        for study in studies.values():
            write_study(study, figures=figures)
        summary = _merge(out, summary, sets, trials, seed)
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        (out / "summary.md").write_text(summary_markdown(summary))
        if figures:
            from symrl.figures import plot_comparison

            qs = ("steps", "total_reinforcement", "neurons", "collisions")
            every = [r for r in summary if not r.startswith("_")]
            plot_comparison(
                {r: {q: curves(read_trials_csv(out / r / "trials.csv"), q) for q in qs}
                 for r in every},
                out / "comparison.png",
                qs,
            )
    return summary


def _merge(
    out: Path, summary: dict[str, Any], sets: int, trials: int, seed: int
) -> dict[str, Any]:
    """Keep the rows of recipes run earlier into the same folder with the same sets, trials and
    seeds (so one recipe, e.g. ``paper``, can be re-run alone); recipes in RECIPES order."""
    old_path = out / "summary.json"
    merged: dict[str, Any] = {}
    runs: list[dict[str, Any]] = []
    if old_path.is_file():
        old = json.loads(old_path.read_text())
        same = old.get("_seeds") == summary["_seeds"] and old.get(
            "_map", "hailu2001") == summary.get("_map", "hailu2001")
        runs = [
            r for r in old.get("_runs", [])
            if same and not set(r["recipes"]) <= {k for k in summary if not k.startswith("_")}
        ]
        for recipe, s in old.items():
            if (
                not recipe.startswith("_") and recipe not in summary and same
                and s.get("sets") == sets and s.get("trials") == trials
                and (out / recipe / "trials.csv").is_file()
            ):
                merged[recipe] = s
    merged.update({r: s for r, s in summary.items() if not r.startswith("_")})
    order = {r: i for i, r in enumerate(RECIPES)}
    result = dict(sorted(merged.items(), key=lambda kv: order.get(kv[0], len(order))))
    result.update({k: v for k, v in summary.items() if k.startswith("_")})
    ran = [k for k in summary if not k.startswith("_")]
    result["_runs"] = [*runs, {"recipes": ran, "wall_time_s": summary["_wall_time_s"]}]
    return result


def ablate_command(args: argparse.Namespace) -> int:
    """`symrl ablate`: run, print the summary table and the wall time."""
    recipes = tuple(r.strip() for r in args.recipes.split(",")) if args.recipes else RECIPES
    summary = run_ablation(recipes, args.sets, args.trials, args.seed, args.workers, args.out,
                           map=args.map)
    print(summary_markdown(summary))
    print(f"wrote {args.out}/ (summary.md, summary.json, comparison.png, one folder per recipe); "
          f"wall time {summary['_wall_time_s']:.1f} s")
    return 0
