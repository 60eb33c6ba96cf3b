"""`symrl study RECIPE`: the paper's repeatability study (N sets x M trials, Table 1, Figs 5-9).

Each set is one independent training run of the recipe with seed ``seed + k``; sets run in
parallel worker processes (one torch thread each). The study writes one results folder:

- ``trials.csv``: one row per (set, trial) with every scalar the trainer reports
- ``table1.md`` / ``table1.json``: mean and variance at the last trial beside the paper's Table 1
  and the optimum of ``symrl plan``
- ``curves.png`` (Figs 7-9), ``trajectories.png`` (Fig 6), ``ghosts.png`` (Fig 5)
- ``sets/set-K.pt``: each finished set with the settings it ran with; a study re-run into the
  same folder with the same settings loads these and trains only the sets missing

Variances are sample variances (ddof = 1) over the sets; the paper does not say which it used.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from symrl.runs import write_trials_csv
from symrl.studies.placement import OTHER_STARTS, study_starts
from symrl.studies.runner import SetResult, curves, optimum, run_sets, start_summary, table1
from symrl.studies.stats import TABLE_KEYS

__all__ = [
    "PAPER_TABLE1",
    "OTHER_STARTS",
    "StudyResult",
    "run_study",
    "table1_markdown",
    "write_study",
    "study_command",
]

PAPER_TABLE1 = {
    "neurons": {"mean": 82.5, "variance": 4.7286},
    "steps": {"mean": 27.7, "variance": 1.9000},
    "total_reinforcement": {"mean": -6.24, "variance": 0.8752},
}
"""Hailu (2001), Table 1: real robot, 10 sets x 20 trials, at the last trial."""


def table1_markdown(
    recipe: str, table: dict[str, Any], opt: dict[str, Any] | None, on_paper_world: bool = True
) -> str:
    """Table 1 beside the paper's numbers (``paper``: only meaningful on its world) and the
    optimum, as Markdown."""
    if not on_paper_world:
        return _table_own_world(recipe, table, opt)
    lines = [
        f"Table 1 - `{recipe}`{_told(table)}: {table['sets']} sets, last trial "
        f"({table['trial']}); variance = sample variance over sets",
        "",
        "| quantity | ours mean | ours variance | ours min-max | paper mean | paper variance "
        "| fewest actions (`symrl plan`) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for key in TABLE_KEYS:
        if key not in table:
            continue
        t = table[key]
        paper = PAPER_TABLE1.get(key, {})
        best = ""
        if opt and key == "steps":
            best = f"{opt['steps']} ({opt['length_m']} m)"
        lines.append(
            f"| {key.replace('_', ' ')} | {t['mean']:.2f} | {t['variance']:.3f} | "
            f"{t['min']:.4g} to {t['max']:.4g} | {paper.get('mean', '')} "
            f"| {paper.get('variance', '')} | {best} |"
        )
    return "\n".join(lines) + "\n"


def _told(table: dict[str, Any]) -> str:
    """`` (knowledge: RUNG)`` when the table records what the robot was told."""
    return f" (knowledge: {table['knowledge']})" if "knowledge" in table else ""


def _table_own_world(recipe: str, table: dict[str, Any], opt: dict[str, Any] | None) -> str:
    """Table 1 on a map other than the paper's: ours and the map's optimum only."""
    lines = [
        f"Table 1 - `{recipe}`{_told(table)} on `{table.get('map', '?')}`: {table['sets']} sets, "
        "last trial "
        f"({table['trial']}); variance = sample variance over sets",
        "",
        "| quantity | ours mean | ours variance | ours min-max | fewest actions (`symrl plan`) |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for key in TABLE_KEYS:
        if key not in table:
            continue
        t = table[key]
        best = f"{opt['steps']} ({opt['length_m']} m)" if opt and key == "steps" else ""
        lines.append(
            f"| {key.replace('_', ' ')} | {t['mean']:.2f} | {t['variance']:.3f} | "
            f"{t['min']:.4g} to {t['max']:.4g} | {best} |"
        )
    return "\n".join(lines) + "\n"


# --- the study ---------------------------------------------------------------------------------


@dataclass
class StudyResult:
    """Every set of a study, in set order, and where its files went."""

    recipe: str
    sets: list[SetResult]
    table: dict[str, Any]
    out: Path | None
    wall_time: float
    world: Any = None

    @property
    def rows(self) -> list[dict[str, Any]]:
        """All trial rows of all sets, set-major."""
        return [row for s in self.sets for row in s.rows]


def run_study(
    recipe: str,
    sets: int = 10,
    trials: int = 20,
    seed: int = 100,
    workers: int | None = 1,
    overrides: Sequence[str] = (),
    out: Path | str | None = None,
    figures: bool = True,
    starts: Sequence[tuple[float, float, float]] | None = None,
    progress: bool = True,
) -> StudyResult:
    """Run ``sets`` sets of ``trials`` trials (set k: seed + k) and write the results folder."""
    from symrl.about import provenance
    from symrl.studies.runner import resolve_config
    from symrl.world import load_map

    t0 = time.perf_counter()
    config = resolve_config(recipe, overrides)
    world = load_map(config.env.map)
    if starts is None:  # the paper's other starts lie in its room; other maps: from the map
        starts = OTHER_STARTS if config.env.map == "hailu2001" else study_starts(world)
    keep = Path(out) / "sets" if out is not None else None  # finished sets, kept for a re-run
    best: dict[str, Any] = {}
    results = run_sets(
        config,
        sets,
        trials,
        seed,
        (),
        starts,
        workers,
        progress=progress,
        keep=keep,
        while_waiting=lambda: best.update(optimum(config.env.map)),
    )
    # one per worker batch (kept sets loaded from disk carry their batch's timings by value)
    batches = {tuple(sorted(r.timings.items())): r.timings for r in results}.values()
    train_cpu = sum(t.get("cpu_seconds", 0.0) for t in batches)
    rows = [r for s in results for r in s.rows]
    table = table1(rows)
    if world.name == "hailu2001":  # the paper's numbers are of its world only
        table["paper"] = PAPER_TABLE1
    table["optimum"] = best
    table["recipe"] = config.recipe
    table["knowledge"] = config.knowledge
    table["provenance"] = provenance()
    table["seeds"] = [seed, seed + sets - 1]
    table["overrides"] = list(overrides)
    table["other_starts"] = start_summary(results)
    table["train_steps"] = int(sum(int(r["steps"]) for r in rows))
    table["train_cpu_s"] = round(train_cpu, 3)
    wall = time.perf_counter() - t0
    table["wall_time_s"] = round(wall, 2)
    study = StudyResult(config.recipe, results, table, Path(out) if out else None, wall, world)
    if out is not None:
        write_study(study, figures=figures)
    return study


def write_study(study: StudyResult, figures: bool = True) -> None:
    """trials.csv, table1.md/json and the figures of a finished study."""
    out = study.out
    assert out is not None
    out.mkdir(parents=True, exist_ok=True)
    write_trials_csv(out / "trials.csv", study.rows)
    own = study.world is not None and study.world.name != "hailu2001"
    if own:
        study.table["map"] = study.world.name
    (out / "table1.json").write_text(json.dumps(study.table, indent=2) + "\n")
    optimum = study.table.get("optimum")
    md = table1_markdown(study.recipe, study.table, optimum, on_paper_world=not own)
    starts = study.table.get("other_starts", [])
    if starts:
        md += (
            "\nFinal controller (greedy) from other start poses: "
            + "; ".join(
                f"({s['start'][0]:g}, {s['start'][1]:g}) {s['reached']}/{s['sets']}" for s in starts
            )
            + "\n"
        )
    (out / "table1.md").write_text(md)
    if figures:
        write_figures(study)


def write_figures(study: StudyResult) -> None:
    """Figs 5-9 of the paper for this study (drawn by ``symrl.drawing``: in the drawing process
    when the command started one)."""
    from symrl import drawing

    out = study.out
    assert out is not None
    rows = study.rows
    world = study.world
    ref: dict[str, float] = {}
    if world is None or world.name == "hailu2001":  # the paper's numbers are of its world only
        ref = {
            "neurons:paper 82.5": 82.5,
            "steps:paper 27.7": 27.7,
            "total_reinforcement:paper -6.24": -6.24,
        }
    opt = study.table.get("optimum")
    if opt:
        ref[f"steps:shortest path {opt['steps']}"] = opt["steps"]
    curves_figure: drawing.Figure = (
        "plot_curves",
        (
            {k: curves(rows, k) for k in ("neurons", "steps", "total_reinforcement")},
            out / "curves.png",
        ),
        {
            "reference": ref,
            "title": f"{study.recipe}: mean over {len(study.sets)} sets, bars min-max (Figs 7-9)",
        },
    )
    s0 = study.sets[0]
    trials = sorted(s0.paths)
    first, last = trials[0], trials[-1]
    first_last: list[tuple[str, list[Any], list[Any]]] = [
        (f"set 0, trial {first} (first)", [s0.paths[first]], []),
        (f"set 0, trial {last} (final)", [s0.paths[last]], []),
    ]
    trajectories_figure: drawing.Figure = (
        "plot_paths",
        (world, first_last, out / "trajectories.png"),
        {},
    )
    success = [t for t in trials if t not in (first, last)]
    panels = [(f"trial {first} (first) + ghosts", [s0.paths[first]], [s0.ghosts[first]])]
    if success:
        t = success[0]
        panels.append((f"trial {t} (first to reach the goal)", [s0.paths[t]], [s0.ghosts[t]]))
    panels.append((f"trial {last} (final) + ghosts", [s0.paths[last]], [s0.ghosts[last]]))
    if s0.evaluations:
        reached = sum(e["reached_goal"] for e in s0.evaluations)
        panels.append(
            (
                f"final controller from {len(s0.evaluations)} other starts "
                f"({reached} reach the goal)",
                [e["path"] for e in s0.evaluations],
                [],
            )
        )
    ghosts_figure: drawing.Figure = (
        "plot_paths",
        (world, panels, out / "ghosts.png"),
        {"columns": 2},
    )
    figures = [ghosts_figure, curves_figure, trajectories_figure]
    set0 = [r for r in rows if int(r["set"]) == s0.index]
    if world is not None and set0 and "stretches" in set0[0]:
        # where set 0 believed each border could be crossed, with the paths the study kept
        records = [{**r, "path": s0.paths.get(int(r["trial"]), [])} for r in set0]
        figures.append(("plot_crossings", (world, records, out / "crossings.png"), {}))
    # largest first: the ghosts' four panels take about as long as the other two figures
    drawing.draw(figures)


def study_command(args: argparse.Namespace) -> int:
    """`symrl study RECIPE`: run the study, print Table 1 and the command's wall time."""
    started = getattr(args, "started", time.perf_counter())
    out = Path(args.out or f"results/study-{Path(args.recipe).stem}")
    study = run_study(
        args.recipe,
        sets=args.sets,
        trials=args.trials,
        seed=args.seed,
        workers=args.workers,
        overrides=[*args.overrides, *([f"env.map={args.map}"] if args.map else [])],
        out=out,
    )
    print((out / "table1.md").read_text())
    print(
        f"wrote {out}/ (trials.csv, table1.md, table1.json, curves.png, trajectories.png, "
        f"ghosts.png); wall time {time.perf_counter() - started:.1f} s, training "
        f"{study.table['train_steps'] / max(study.table['train_cpu_s'], 1e-9):.0f} "
        "robot-steps per CPU second"
    )
    return 0
