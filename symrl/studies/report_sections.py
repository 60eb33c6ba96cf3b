"""RESULTS.md's sections of the paper's studies (the optimum, Table 1, the studies, the
knowledge ladder, the ablations, the changes of ``paper_map``, generalisation): each reads the
folder its command wrote and returns its Markdown lines."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from symrl.studies.report_files import copy_figure, load_json, measured_at

COMMANDS = {
    "plan": "symrl plan --out results/plan",
    "ablate": "symrl ablate --sets 10 --trials 20 --seed 100 --out results/ablate",
    "changes": "symrl ablate --changes-of paper_map --recipes paper_literal,reflex_only "
    "--sets 10 --trials 20 --seed 100 --out results/changes-s100",
    "generalise": "symrl generalise --recipe {recipe} --out results/generalise-{recipe}",
}
"""The commands whose folders this report reads (the baselines': ``BASELINE_VARIANTS``)."""

RECIPE_ORDER = (
    "paper",
    "paper_map",
    "paper_literal",
    "no_partition",
    "reflex_only",
    "no_reflex",
    "plain",
)
"""The order of the recipes in the tables: the headline learners first."""

STUDIED = ("paper", "paper_map")
"""Recipes whose whole study (Table 1 and Figs 5-9) the report shows."""

GENERALISE_RECIPES = ("reflex_only", "paper", "paper_map")
"""The recipes of the generalisation section, one per rung of knowledge: the reflex alone
(sensors), the paper's learner (regions), the learner told the whole map (map)."""


def section_plan(results: Path, figures: Path) -> list[str]:
    plan = load_json(results / "plan" / "plan.json")
    out = ["## The optimum (`symrl plan`)", "", f"Command: `{COMMANDS['plan']}`", ""]
    if plan is None:
        return out + ["*Not run yet.*", ""]
    lb, walk, replay = plan["lower_bound"], plan["chord_walk"], plan["env_replay_noise_free"]
    out += [
        "The planner is exact and deterministic (no seeds): the numbers are those of the code "
        "this report was built from.",
        "",
        f"- Method: {plan['method']}; length error bound {plan['length_error_bound_m']:g} m.",
        f"- Shortest path keeping {plan['clearance_m']:.3f} m (body 0.26 + IR 0.056) from every "
        f"wall: **{plan['length_m']:.3f} m = {plan['actions']} actions** of 0.20 m.",
        "- Lower bound with the body radius only (a sweep between poses may pass closer than an "
        f"end pose): {lb['length_m']:.3f} m = {lb['actions']} actions; a walk of {walk['moves']} "
        f"0.20 m moves along the path has {walk['sweep_contacts']} sweep contacts and "
        f"{walk['virtual_collisions']} virtual collisions, so **{plan['actions']} actions is the "
        f"exact optimum** under the env's rules"
        + ("." if plan["optimum_actions_exact"] else " - NOT confirmed (see plan.json)."),
        f"- Replayed in the env without noise: {replay}. The shortest path hugs the door post, so "
        "its total reinforcement (f1 near walls) is far from the best reachable total: steps and "
        "reinforcement are optimised by different paths."
        if replay
        else "- (no env replay)",
        "",
        copy_figure(results / "plan" / "plan.png", figures, "plan.png"),
        "",
    ]
    return out


def _recipes_in(folder: Path) -> list[str]:
    """The recipes with a study under ``folder``, headline learners first."""
    found = [p.parent.name for p in folder.glob("*/table1.json")]
    return sorted(found, key=lambda r: (RECIPE_ORDER.index(r) if r in RECIPE_ORDER else 99, r))


def _inputs(recipe: str) -> tuple[str, str, bool]:
    """(knowledge rung, what the experts read, whether its neurons compare with the paper's):
    only experts that grow on the paper's input (the sonars and goal codes) do."""
    from symrl.learner.config import load_config

    config = load_config(recipe)
    if not config.experts.learning:
        return config.knowledge, "no experts", False
    return config.knowledge, config.experts.input, config.experts.input == "sensors"


def _at_last(table: dict[str, Any], key: str, digits: int) -> str:
    """A measure at the last trial: mean (sample variance over the sets)."""
    t = table[key]
    return f"{t['mean']:.{digits}f} ({t['variance']:.{digits + 1}f})"


def _last5(summary: dict[str, Any], key: str, digits: int) -> str:
    """A measure's last-5-trial mean per set: mean ± sd over the sets."""
    t = summary.get(f"{key}_last5")
    return f"{t['mean']:.{digits}f} ± {t['std']:.{digits}f}" if t else "-"


def table1_comparison(results: Path) -> str:
    """The paper's Table 1 on its own measure (the last trial's mean and variance over sets)
    for every recipe of the ablation, with the last-5 mean beside it."""
    from symrl.studies.repeatability import PAPER_TABLE1

    folder = results / "ablate"
    summary = load_json(folder / "summary.json") or {}
    paper = PAPER_TABLE1
    lines = [
        "| recipe | knowledge | experts read | steps, last trial: mean (var) | steps, last 5 "
        "| total reinf., last trial: mean (var) | total reinf., last 5 | neurons, last trial: "
        "mean (var) |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: |",
        f"| *the paper's robot (Table 1)* | regions | sensors | {paper['steps']['mean']} "
        f"({paper['steps']['variance']}) | - | {paper['total_reinforcement']['mean']} "
        f"({paper['total_reinforcement']['variance']}) | - | {paper['neurons']['mean']} "
        f"({paper['neurons']['variance']}) |",
    ]
    for recipe in _recipes_in(folder):
        table = load_json(folder / recipe / "table1.json") or {}
        rung, reads, comparable = _inputs(recipe)
        last5 = summary.get(recipe, {})
        neurons = _at_last(table, "neurons", 1) if comparable else f"not comparable ({reads})"
        lines.append(
            f"| `{recipe}` | {rung} | {reads} | {_at_last(table, 'steps', 1)} "
            f"| {_last5(last5, 'steps', 1)} | {_at_last(table, 'total_reinforcement', 2)} "
            f"| {_last5(last5, 'total_reinforcement', 2)} | {neurons} |"
        )
    return "\n".join(lines) + "\n"


def section_table1(results: Path, figures: Path) -> list[str]:
    folder = results / "ablate"
    out = [
        "## Table 1 on the paper's measures",
        "",
        f"Command: `{COMMANDS['ablate']}` (one study per recipe, the same seeds)",
        "",
    ]
    recipes = _recipes_in(folder)
    if not recipes:
        return out + ["*Not run yet.*", ""]
    tables = [load_json(folder / r / "table1.json") for r in recipes]
    out += [
        measured_at(*tables),
        "",
        "The paper's Table 1 gives, over its 10 sets of 20 trials on the real robot, the mean "
        "and the variance of each measure at the **last trial**; the same columns come first "
        "here, with the mean ± sd over the sets of each set's last-5-trial mean beside them. "
        "Variances are sample variances over the sets (ddof 1; the paper does not say which it "
        "used). **Neurons are compared only where the inputs match**: the paper's experts grow "
        "on the sonars and goal codes, as `experts.input: sensors` does; a recipe whose experts "
        "read the odometry pose grows a neuron per 0.5 m of pose instead, a different count.",
        "",
        table1_comparison(results),
    ]
    return out


def section_study(results: Path, figures: Path) -> list[str]:
    out: list[str] = []
    for recipe in STUDIED:
        folder = results / "ablate" / recipe
        table = load_json(folder / "table1.json")
        if table is None:
            continue
        out += [
            f"## Table 1 and Figs 5-9: `{recipe}` (`symrl study {recipe}`)",
            "",
            f"Command: `{COMMANDS['ablate']}` (its `{recipe}` folder holds the same runs as "
            f"`symrl study {recipe} --sets 10 --trials 20 --seed 100`)",
            "",
            measured_at(table),
            "",
            (folder / "table1.md").read_text(),
            f"Wall time {table.get('wall_time_s')} s (2 shared cores); seeds "
            f"{table['seeds'][0]}-{table['seeds'][1]}.",
            "",
            "Learning curves (Figs 7-9; mean over sets, bars min-max):",
            "",
            copy_figure(folder / "curves.png", figures, f"study-{recipe}-curves.png"),
            "",
            "First and final trajectories of set 0 (Fig 6):",
            "",
            copy_figure(folder / "trajectories.png", figures, f"study-{recipe}-trajectories.png"),
            "",
            "Paths with neuron-toggle ghosts, and the final controller from four other starts "
            "(Fig 5):",
            "",
            copy_figure(folder / "ghosts.png", figures, f"study-{recipe}-ghosts.png"),
            "",
        ]
    return out


def section_changes(results: Path, figures: Path) -> list[str]:
    folder = results / "changes-s100"
    out = [
        "## Which setting of `paper_map` buys what (`symrl ablate --changes-of paper_map`)",
        "",
        f"Command: `{COMMANDS['changes']}`",
        "",
    ]
    changes = folder / "changes.md"
    if not changes.is_file():
        return out + ["*Not run yet.*", ""]
    tables = [load_json(p) for p in sorted(folder.glob("*/table1.json"))]
    out += [
        measured_at(*tables),
        "",
        "Each setting in which `paper_map` differs from `paper_literal`, put back in turn; Δ is "
        "the paired difference over the sets (mean ± standard error), positive: `paper_map` is "
        "better with its setting.",
        "",
        changes.read_text(),
    ]
    return out


def section_ladder(results: Path, figures: Path) -> list[str]:
    """What each rung of knowledge buys: the ladder's recipes out of the ablation's folder."""
    from symrl.studies.ablation import LADDER, ladder_markdown

    folder = results / "ablate"
    out = [
        "## The knowledge ladder (`symrl ablate --ladder`)",
        "",
        f"From the ablation's folder (command: `{COMMANDS['ablate']}`; "
        "`symrl ablate --ladder` runs these recipes alone).",
        "",
    ]
    summary = load_json(folder / "summary.json")
    if summary is None or not all(r in summary for r in LADDER):
        return out + ["*Not run yet.*", ""]
    rows = {r: summary[r] for r in LADDER}
    rows.update({k: v for k, v in summary.items() if k.startswith("_")})
    out += [measured_at(*(load_json(folder / r / "table1.json") for r in LADDER)), ""]
    return out + [
        ladder_markdown(rows),
        "Mean ± std over sets of each set's last-5-trial mean "
        "(trial 1: its first trial); the paper's row is its own measure, the last "
        "trial.",
        "",
    ]


def section_ablate(results: Path, figures: Path) -> list[str]:
    from symrl.studies.ablation import summary_markdown

    folder = results / "ablate"
    out = [
        "## Ablations (`symrl ablate`)",
        "",
        f"Command: `{COMMANDS['ablate']}` (a recipe can be "
        "re-run alone with `--recipes NAME`; the folder keeps the others)",
        "",
    ]
    summary = load_json(folder / "summary.json")
    if summary is None:
        return out + ["*Not run yet.*", ""]
    out += [measured_at(*(load_json(folder / r / "table1.json") for r in _recipes_in(folder))), ""]
    cpu = ", ".join(
        f"{r} {s['wall_time_s']:.0f} s" for r, s in summary.items() if not r.startswith("_")
    )
    out += [
        summary_markdown(summary),
        "Mean ± std over sets. Steps and total reinforcement: per set the mean over its last 5 "
        "trials (a failed trial counts with its 200 actions). First success: first trial that "
        "reached the goal (sets that never did in brackets).",
        "",
        f"CPU time per recipe (sum over its sets): {cpu}. Wall time (2 workers): "
        + "; ".join(
            f"{', '.join(r['recipes'])}: {r['wall_time_s']:.0f} s" for r in summary.get("_runs", [])
        )
        + f". Seeds {summary['_seeds'][0]}-{summary['_seeds'][1]}.",
        "",
        copy_figure(folder / "comparison.png", figures, "ablate-comparison.png"),
        "",
    ]
    for recipe in ("paper_literal",):
        t = folder / recipe / "table1.md"
        if t.is_file():
            out += [t.read_text(), ""]
            name = f"ablate-{recipe}-curves.png"
            out += [copy_figure(folder / recipe / "curves.png", figures, name), ""]
    return out


def section_generalise(results: Path, figures: Path) -> list[str]:
    out = [
        "## Generalisation (`symrl generalise`)",
        "",
        "One recipe per rung of what the robot is told: `reflex_only` (its sensors), `paper` "
        "(+ the region rules), `paper_map` (+ the map). The new obstacle is in the env's "
        "world only, never in what the robot is told.",
        "",
    ]
    for recipe in GENERALISE_RECIPES:
        folder = results / f"generalise-{recipe}"
        out += [
            f"### `{recipe}`",
            "",
            f"Command: `{COMMANDS['generalise'].format(recipe=recipe)}`",
            "",
        ]
        data = load_json(folder / "generalise.json")
        if data is None:
            out += ["*Not run yet.*", ""]
            continue
        out += [
            measured_at(data),
            "",
            (folder / "generalise.md").read_text(),
            f"Wall time {data['wall_time_s']} s.",
            "",
            copy_figure(folder / "starts.png", figures, f"generalise-{recipe}-starts.png"),
            "",
            copy_figure(folder / "obstacle.png", figures, f"generalise-{recipe}-obstacle.png"),
            "",
        ]
    return out
