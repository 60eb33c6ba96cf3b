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

``--changes-of RECIPE`` asks which of a recipe's settings matter: RECIPE, then RECIPE with each
setting in which it differs from a base recipe (``paper_literal``) put back in turn, and RECIPE
with the experts' learning off (their share). ``changes.md`` has one row per setting with the
paired difference over sets (the same seeds, so the sets' luck cancels).

What is compared (:mod:`symrl.studies.ablation_variants`) and the tables
(:mod:`symrl.studies.ablation_tables`) have modules of their own.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from symrl.learner.config import load_config
from symrl.runs import read_trials_csv
from symrl.studies.ablation_tables import (
    changes_markdown,
    ladder_markdown,
    summary_markdown,
)
from symrl.studies.ablation_variants import LADDER, RECIPES, Variant, changes_of
from symrl.studies.repeatability import (
    PAPER_TABLE1,
    StudyResult,
    write_study,
)
from symrl.studies.runner import (
    curves,
    optimum,
    run_sets,
    start_summary,
    summarise,
    table1,
)

__all__ = [
    "RECIPES",
    "LADDER",
    "Variant",
    "changes_of",
    "changes_markdown",
    "ladder_markdown",
    "summarise",
    "summary_markdown",
    "run_ablation",
    "ablate_command",
]


def run_ablation(
    recipes: Sequence[str | Variant] = RECIPES,
    sets: int = 10,
    trials: int = 20,
    seed: int = 100,
    workers: int | None = 1,
    out: Path | str | None = "results/ablate",
    figures: bool = True,
    starts: Sequence[tuple[float, float, float]] | None = None,
    map: str = "hailu2001",
    keep_sets: bool = False,
) -> dict[str, Any]:
    """Run every recipe's study on the same seeds in ``map`` (name or file; each recipe trained
    with ``env.map=map``); return (and write) the summary. ``recipes``: names, or
    :class:`Variant` rows (a recipe with overrides, e.g. from :func:`changes_of`; then
    ``changes.md`` is written too). ``starts``: where the final controllers are also driven
    from (default: the paper's four on its world, the map's own or derived poses elsewhere,
    ``symrl.studies.placement.study_starts``)."""
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
    variants = [r if isinstance(r, Variant) else Variant(r, r) for r in recipes]
    names = [v.name for v in variants]
    if len(set(names)) != len(names):
        raise ValueError(f"run_ablation: variant names repeat: {names}")
    summary: dict[str, Any] = {}
    studies: dict[str, StudyResult] = {}
    for variant in variants:
        recipe = variant.name
        folder = Path(out) / recipe if out else None
        keep = folder / "sets" if keep_sets and folder else None
        study = _run_variant(
            variant, sets, trials, seed, workers, starts, (map, world), keep, opt, code
        )
        study.out = folder
        studies[recipe] = study
        summary[recipe] = summarise(study.rows)
        summary[recipe]["wall_time_s"] = round(study.wall_time, 1)
    wall = time.perf_counter() - t0
    summary["_optimum"] = opt
    summary["_map"] = world.name
    summary["_seeds"] = [seed, seed + sets - 1]
    summary["_wall_time_s"] = round(wall, 1)
    if out is not None:
        summary = _write_ablation(
            Path(out), variants, studies, summary, sets, trials, seed, figures
        )
    return summary


def _run_variant(
    variant: Variant,
    sets: int,
    trials: int,
    seed: int,
    workers: int | None,
    starts: Sequence[tuple[float, float, float]],
    where: tuple[str, Any],
    keep: Path | None,
    opt: dict[str, Any],
    code: dict[str, Any],
) -> StudyResult:
    """One row of an ablation: ``variant``'s sets in ``where`` (the map as given and as loaded;
    kept in ``keep``), and its Table 1 with what the ablation knows of it (``opt``: the map's
    optimum, ``code``: the provenance). Its folder is left unset."""
    map, world = where
    r0 = time.perf_counter()
    sets_r = run_sets(
        variant.recipe,
        sets,
        trials,
        seed,
        [f"env.map={map}", *variant.overrides],
        starts,
        workers,
        keep=keep,
    )
    rows = [r for s in sets_r for r in s.rows]
    table = table1(rows)
    table.update(
        optimum=opt,
        recipe=variant.name,
        seeds=[seed, seed + sets - 1],
        knowledge=load_config(variant.recipe, list(variant.overrides)).knowledge,
    )
    if variant.overrides:
        table["overrides"] = list(variant.overrides)
    if world.name == "hailu2001":  # the paper's numbers are of its world only
        table["paper"] = PAPER_TABLE1
    table["other_starts"] = start_summary(sets_r)
    table["provenance"] = code
    wall_r = time.perf_counter() - r0
    table["wall_time_s"] = round(wall_r, 1)
    table["map"] = world.name
    return StudyResult(variant.name, sets_r, table, None, wall_r, world)


def _write_ablation(
    out: Path,
    variants: list[Variant],
    studies: dict[str, StudyResult],
    summary: dict[str, Any],
    sets: int,
    trials: int,
    seed: int,
    figures: bool,
) -> dict[str, Any]:
    """Write every study's folder, ``summary.json`` / ``summary.md`` (merged with the recipes
    run earlier into ``out``), ``changes.md`` and ``comparison.png``; return the merged
    summary."""
    out.mkdir(parents=True, exist_ok=True)
    for study in studies.values():
        write_study(study, figures=figures)
    summary = _merge(out, summary, sets, trials, seed)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "summary.md").write_text(summary_markdown(summary))
    if any(v.change for v in variants):
        (out / "changes.md").write_text(
            changes_markdown(variants, {v.name: studies[v.name].rows for v in variants})
        )
    if figures:
        from symrl.figures import plot_comparison

        qs = ("steps", "total_reinforcement", "neurons", "collisions")
        # one curve per recipe; of a change ablation only the full recipe and experts off
        # (a curve per setting would hide them all: changes.md has those)
        put_back = {v.name for v in variants if v.change and not v.name.endswith("-experts-off")}
        every = [r for r in summary if not r.startswith("_") and r not in put_back]
        plot_comparison(
            {r: {q: curves(read_trials_csv(out / r / "trials.csv"), q) for q in qs} for r in every},
            out / "comparison.png",
            qs,
        )
    return summary


def _merge(out: Path, summary: dict[str, Any], sets: int, trials: int, seed: int) -> dict[str, Any]:
    """Keep the rows of recipes run earlier into the same folder with the same sets, trials and
    seeds (so one recipe, e.g. ``paper``, can be re-run alone); recipes in RECIPES order."""
    old_path = out / "summary.json"
    merged: dict[str, Any] = {}
    runs: list[dict[str, Any]] = []
    if old_path.is_file():
        old = json.loads(old_path.read_text())
        same = old.get("_seeds") == summary["_seeds"] and old.get(
            "_map", "hailu2001"
        ) == summary.get("_map", "hailu2001")
        runs = [
            r
            for r in old.get("_runs", [])
            if same and not set(r["recipes"]) <= {k for k in summary if not k.startswith("_")}
        ]
        for recipe, s in old.items():
            if (
                not recipe.startswith("_")
                and recipe not in summary
                and same
                and s.get("sets") == sets
                and s.get("trials") == trials
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
    """`symrl ablate`: run, print the summary table (and the changes table) and the wall
    time."""
    named = tuple(r.strip() for r in args.recipes.split(",")) if args.recipes else ()
    changes = getattr(args, "changes_of", None)
    ladder = getattr(args, "ladder", False)
    if ladder and (named or changes):
        raise ValueError("--ladder runs its own recipes: give it without --recipes or --changes-of")
    named = LADDER if ladder else named
    recipes: list[str | Variant] = []
    if changes:
        recipes += changes_of(changes, args.base)
    recipes += [
        r
        for r in named or (() if changes else RECIPES)
        if r not in {v.name for v in recipes if isinstance(v, Variant)}
    ]
    from symrl.studies import checkpointing

    settings = {
        "variants": [
            [v.name, v.recipe, list(v.overrides)] if isinstance(v, Variant) else v for v in recipes
        ],
        "sets": args.sets,
        "trials": args.trials,
        "seed": args.seed,
        "map": args.map,
    }
    with checkpointing.running(args.out, "ablate", settings, bool(getattr(args, "resume", 0))):
        summary = run_ablation(
            recipes,
            args.sets,
            args.trials,
            args.seed,
            args.workers,
            args.out,
            map=args.map,
            keep_sets=True,
        )
    print(summary_markdown(summary))
    if ladder:
        table = ladder_markdown(summary)
        (Path(args.out) / "ladder.md").write_text(table)
        print(table)
    written = "summary.md, summary.json, comparison.png, one folder per recipe"
    if changes:
        print((Path(args.out) / "changes.md").read_text())
        written = "changes.md, " + written
    wall = time.perf_counter() - getattr(args, "started", time.perf_counter())
    print(f"wrote {args.out}/ ({written}); wall time {wall:.1f} s")
    return 0
