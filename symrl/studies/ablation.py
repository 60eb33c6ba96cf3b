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
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel

from symrl.learner.config import load_config
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

__all__ = [
    "RECIPES",
    "Variant",
    "changes_of",
    "changes_markdown",
    "summarise",
    "summary_markdown",
    "run_ablation",
    "ablate_command",
]

LADDER = ("reflex_only", "paper_literal", "paper", "paper_passages", "paper_map")
"""``symrl ablate --ladder``: the best recipe of each knowledge rung, and the paper's literal
learner, on the same seeds."""

RECIPES = (
    "paper",
    "paper_passages",
    "paper_map",
    "paper_literal",
    "no_partition",
    "no_reflex",
    "plain",
    "reflex_only",
)

# what a change ablation leaves alone: the recipe's name, and the budget, seed and logging
_NOT_CHANGES = ("recipe", "run.")


@dataclasses.dataclass(frozen=True)
class Variant:
    """One row of an ablation: ``recipe`` with ``overrides``, run and written as ``name``.
    ``change``: the setting put back (``"key: recipe value -> base value"``), if any."""

    name: str
    recipe: str
    overrides: tuple[str, ...] = ()
    change: str | None = None


def _leaves(config: Any) -> dict[str, Any]:
    """Every setting of a config as dotted key -> plain value (as ``config_to_dict`` writes it:
    tuples as lists). Sections recurse; a setting whose value is a dict or a list, such as
    ``reflex.near``, is one setting."""
    from symrl.learner.config import config_to_dict

    out: dict[str, Any] = {}

    def walk(node: Any, plain: Any, prefix: str) -> None:
        if isinstance(node, BaseModel):
            names = list(type(node).model_fields)
        elif dataclasses.is_dataclass(node) and not isinstance(node, type):
            names = [f.name for f in dataclasses.fields(node)]
        else:
            out[prefix] = plain
            return
        for name in names:
            walk(getattr(node, name), plain[name], f"{prefix}.{name}" if prefix else name)

    walk(config, config_to_dict(config), "")
    return out


def changes_of(recipe: str, base: str = "paper_literal") -> list[Variant]:
    """``recipe``, then ``recipe`` with each setting in which it differs from ``base`` set back
    to ``base``'s value (one at a time, in config order), then ``recipe`` with
    ``experts.learning=false`` if its experts learn. Names: ``RECIPE``, ``RECIPE-without-KEY``,
    ``RECIPE-experts-off``. A setting that only matters under another (``options.*`` with
    ``options.enabled``) is still its own row: put back with the rest of ``recipe`` kept. A
    setting that cannot be put back alone (the config it gives is refused, e.g.
    ``options.source=map`` below the map rung) has no row."""
    from symrl.learner.config import ConfigError, load_config

    mine, theirs = load_config(recipe), load_config(base)
    name = mine.recipe
    ours, other = _leaves(mine), _leaves(theirs)
    variants = [Variant(name, recipe)]
    for key, value in ours.items():
        if key.startswith(_NOT_CHANGES) or other.get(key) == value:
            continue
        back = other[key]
        try:
            load_config(recipe, [f"{key}={json.dumps(back)}"])
        except ConfigError:
            continue
        shown = (value, back)
        if isinstance(value, dict) and isinstance(back, dict):  # only the entries that differ
            keys = [k for k in {**back, **value} if value.get(k) != back.get(k)]
            shown = ({k: value.get(k) for k in keys}, {k: back.get(k) for k in keys})
        variants.append(
            Variant(
                f"{name}-without-{key}",
                recipe,
                (f"{key}={json.dumps(back)}",),
                f"{key}: {_short(shown[0])} -> {_short(shown[1])}",
            )
        )
    if mine.experts.learning:
        variants.append(
            Variant(
                f"{name}-experts-off",
                recipe,
                ("experts.learning=false",),
                "experts.learning: true -> false",
            )
        )
    return variants


def _short(value: Any) -> str:
    """A setting's value for a table cell (floats to 4 significant digits)."""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, list):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_short(v)}" for k, v in value.items()) + "}"
    return str(value)


def changes_markdown(
    variants: Sequence[Variant], rows: dict[str, Sequence[dict[str, Any]]], last: int = LAST
) -> str:
    """One row per variant: its total over the last ``last`` trials and over all trials (means
    over sets), each with the paired difference from the first variant (the full recipe), mean
    ± standard error over sets (positive: the recipe is better with the setting); the last
    trials' actions, the neurons at the last trial, collisions (per trial in the last ``last``
    / per set over all trials) and the trials from trial 5 on that failed. Every variant ran
    the same sets and trials."""
    full = curves(rows[variants[0].name], "total_reinforcement")  # (sets, trials)
    lines = [
        f"| variant | setting put back | total last {last} | Δ last {last} (paired) "
        "| total, all trials | Δ all trials (paired) "
        f"| actions last {last} | neurons last | collisions last {last} / all trials "
        "| failed trials from 5 |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for i, v in enumerate(variants):
        r = rows[v.name]
        total = curves(r, "total_reinforcement")
        cells = []
        for window in (slice(-last, None), slice(None)):  # the last trials; all of them
            per_set = total[:, window].mean(axis=1)
            cells.append(f"{per_set.mean():.2f}")
            if i == 0:
                cells.append("-")
                continue
            d = full[:, window].mean(axis=1) - per_set
            se = d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else float("nan")
            cells.append(f"{d.mean():+.2f} ± {se:.2f}")
        steps, collisions = curves(r, "steps"), curves(r, "collisions")
        neurons = curves(r, "neurons")[:, -1]
        failed = sum(1 for x in r if int(x["trial"]) >= 5 and not _reached(x))
        lines.append(
            f"| {v.name} | {v.change or '-'} | {' | '.join(cells)} "
            f"| {steps[:, -last:].mean():.1f} | {neurons.mean():.0f} "
            f"| {collisions[:, -last:].mean():.2f} / {collisions.sum(axis=1).mean():.1f} "
            f"| {failed} |"
        )
    return "\n".join(lines) + "\n"


def _reached(row: dict[str, Any]) -> bool:
    value = row["reached_goal"]
    return value is True or str(value) == "True"


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


def ladder_markdown(summary: dict[str, dict[str, Any]], last: int = LAST) -> str:
    """The knowledge ladder: per recipe, its rung and what the robot is told, and what that
    buys (last-``last`` means over the sets), with the paper's real robot for reference."""
    from symrl.knowledge.rungs import TOLD
    from symrl.learner.config import load_config

    lines = [
        f"| rung | recipe | what the robot is told | total reinf. trial 1 "
        f"| total reinf. last {last} | actions last {last} | neurons last "
        f"| collisions last {last} (all sets) |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    from symrl.knowledge.rungs import RUNGS

    rungs = {r: load_config(r).knowledge for r in summary if not r.startswith("_")}
    order = {r: i for i, r in enumerate(LADDER)}
    for recipe in sorted(rungs, key=lambda r: (RUNGS.index(rungs[r]), order.get(r, 99), r)):
        s, rung = summary[recipe], rungs[recipe]
        lines.append(
            f"| {rung} | `{recipe}` | {TOLD[rung]} "
            f"| {_pm(s['total_reinforcement_first'], '.2f')} "
            f"| {_pm(s[f'total_reinforcement_last{last}'], '.2f')} "
            f"| {_pm(s[f'steps_last{last}'])} | {_pm(s['neurons_last'])} "
            f"| {s.get(f'collisions_last{last}_sum', '-')} |"
        )
    p = PAPER_TABLE1
    if summary.get("_map", "hailu2001") == "hailu2001":
        lines.append(
            f"| regions | *paper, real robot (Table 1, last trial)* | {TOLD['regions']} | - "
            f"| {p['total_reinforcement']['mean']} | {p['steps']['mean']} "
            f"| {p['neurons']['mean']} | - |"
        )
    return "\n".join(lines) + "\n"


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
        r0 = time.perf_counter()
        sets_r = run_sets(
            variant.recipe,
            sets,
            trials,
            seed,
            [f"env.map={map}", *variant.overrides],
            starts,
            workers,
            keep=Path(out) / recipe / "sets" if keep_sets and out else None,
        )
        rows = [r for s in sets_r for r in s.rows]
        table = table1(rows)
        table.update(
            optimum=opt,
            recipe=recipe,
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
        study = StudyResult(
            recipe, sets_r, table, Path(out) / recipe if out else None, wall_r, world
        )
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
        if any(v.change for v in variants):
            (out / "changes.md").write_text(
                changes_markdown(variants, {n: studies[n].rows for n in names})
            )
        if figures:
            from symrl.figures import plot_comparison

            qs = ("steps", "total_reinforcement", "neurons", "collisions")
            # one curve per recipe; of a change ablation only the full recipe and experts off
            # (a curve per setting would hide them all: changes.md has those)
            put_back = {
                v.name for v in variants if v.change and not v.name.endswith("-experts-off")
            }
            every = [r for r in summary if not r.startswith("_") and r not in put_back]
            plot_comparison(
                {
                    r: {q: curves(read_trials_csv(out / r / "trials.csv"), q) for q in qs}
                    for r in every
                },
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
