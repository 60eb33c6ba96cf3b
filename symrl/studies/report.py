"""Regenerate RESULTS.md from the results folders the study commands wrote.

Run the commands in ``COMMANDS`` and ``BASELINE_VARIANTS`` (they write under ``results/``, which
git ignores), then ``python -m symrl.studies.report``: it copies the figures to ``docs/figures/``
and writes ``RESULTS.md`` with every table, the command that made it, the commit its numbers
were measured at, and the paper's numbers beside ours. A section whose results folder is
missing keeps its text from the previous ``RESULTS.md`` (with the commit it names) and says it
was not re-run; without a previous text it says "Not run yet" instead of failing.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
from pathlib import Path
from typing import Any

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

INTERPRETATION = Path(__file__).with_name("results_discussion.md")
"""Hand-written discussion appended to the generated report (what reproduces and what not)."""

NOT_RERUN = (
    "*Not re-run in this build (its results folder is missing): the text below is the previous "
    "RESULTS.md's, measured at the commit it names.*"
)


def _load(path: Path) -> Any | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _fig(src: Path, figures: Path, name: str) -> str:
    """Copy a figure into docs/figures and return its Markdown image link (or a note)."""
    if not src.is_file():
        return f"*(figure {src} not produced yet)*"
    figures.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, figures / name)
    return f"![{name}](docs/figures/{name})"


def measured_at(*records: dict[str, Any] | None) -> str:
    """The commit (and version) the numbers of a section were measured at, from the
    ``provenance`` its result files record; every distinct one when they differ."""
    seen: list[str] = []
    for record in records:
        info = (record or {}).get("provenance") or {}
        if not info.get("revision"):
            continue
        text = f"`{info['revision']}`" + (" with uncommitted changes" if info.get("dirty") else "")
        text += f" (symrl {info['symrl']})" if info.get("symrl") else ""
        if text not in seen:
            seen.append(text)
    if not seen:
        return "Measured at: the result files record no commit."
    return "Measured at commit " + ", ".join(seen) + "."


def _section_plan(results: Path, figures: Path) -> list[str]:
    plan = _load(results / "plan" / "plan.json")
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
        _fig(results / "plan" / "plan.png", figures, "plan.png"),
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
    summary = _load(folder / "summary.json") or {}
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
        table = _load(folder / recipe / "table1.json") or {}
        rung, reads, comparable = _inputs(recipe)
        last5 = summary.get(recipe, {})
        neurons = _at_last(table, "neurons", 1) if comparable else f"not comparable ({reads})"
        lines.append(
            f"| `{recipe}` | {rung} | {reads} | {_at_last(table, 'steps', 1)} "
            f"| {_last5(last5, 'steps', 1)} | {_at_last(table, 'total_reinforcement', 2)} "
            f"| {_last5(last5, 'total_reinforcement', 2)} | {neurons} |"
        )
    return "\n".join(lines) + "\n"


def _section_table1(results: Path, figures: Path) -> list[str]:
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
    tables = [_load(folder / r / "table1.json") for r in recipes]
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


def _section_study(results: Path, figures: Path) -> list[str]:
    out: list[str] = []
    for recipe in STUDIED:
        folder = results / "ablate" / recipe
        table = _load(folder / "table1.json")
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
            _fig(folder / "curves.png", figures, f"study-{recipe}-curves.png"),
            "",
            "First and final trajectories of set 0 (Fig 6):",
            "",
            _fig(folder / "trajectories.png", figures, f"study-{recipe}-trajectories.png"),
            "",
            "Paths with neuron-toggle ghosts, and the final controller from four other starts "
            "(Fig 5):",
            "",
            _fig(folder / "ghosts.png", figures, f"study-{recipe}-ghosts.png"),
            "",
        ]
    return out


def _section_changes(results: Path, figures: Path) -> list[str]:
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
    tables = [_load(p) for p in sorted(folder.glob("*/table1.json"))]
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


def _section_ladder(results: Path, figures: Path) -> list[str]:
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
    summary = _load(folder / "summary.json")
    if summary is None or not all(r in summary for r in LADDER):
        return out + ["*Not run yet.*", ""]
    rows = {r: summary[r] for r in LADDER}
    rows.update({k: v for k, v in summary.items() if k.startswith("_")})
    out += [measured_at(*(_load(folder / r / "table1.json") for r in LADDER)), ""]
    return out + [
        ladder_markdown(rows),
        "Mean ± std over sets of each set's last-5-trial mean "
        "(trial 1: its first trial); the paper's row is its own measure, the last "
        "trial.",
        "",
    ]


def _section_ablate(results: Path, figures: Path) -> list[str]:
    from symrl.studies.ablation import summary_markdown

    folder = results / "ablate"
    out = [
        "## Ablations (`symrl ablate`)",
        "",
        f"Command: `{COMMANDS['ablate']}` (a recipe can be "
        "re-run alone with `--recipes NAME`; the folder keeps the others)",
        "",
    ]
    summary = _load(folder / "summary.json")
    if summary is None:
        return out + ["*Not run yet.*", ""]
    out += [measured_at(*(_load(folder / r / "table1.json") for r in _recipes_in(folder))), ""]
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
        _fig(folder / "comparison.png", figures, "ablate-comparison.png"),
        "",
    ]
    for recipe in ("paper_literal",):
        t = folder / recipe / "table1.md"
        if t.is_file():
            out += [t.read_text(), ""]
            name = f"ablate-{recipe}-curves.png"
            out += [_fig(folder / recipe / "curves.png", figures, name), ""]
    return out


BASELINE_VARIANTS = (
    (
        "paper-20",
        "paper learner (`paper_map`)",
        "symrl sweep --recipes paper_map --seeds 100-104 "
        "--trials 20 --out results/baselines/paper-20",
    ),
    (
        "reflex-20",
        "reference: the shielded reflex alone (no learning)",
        "symrl sweep --recipes "
        "paper_map --seeds 100-104 --trials 20 --out results/baselines/reflex-20 "
        "experts.learning=false options.enabled=false "
        "'reflex.peaks=[1.5707963267948966,0.0,-1.5707963267948966]'",
    ),
    (
        "sac-scratch",
        "SAC from scratch",
        "symrl baseline sac --episodes {n} --seeds 100-104 --out results/baselines/sac-scratch",
    ),
    (
        "sac-residual",
        "SAC residual",
        "symrl baseline sac --residual --episodes {n} "
        "--seeds 100-104 --out results/baselines/sac-residual",
    ),
    (
        "sac-residual+regions",
        "SAC residual + regions",
        "symrl baseline sac --residual "
        "--regions --episodes {n} --seeds 100-104 --out results/baselines/sac-residual+regions",
    ),
    (
        "ppo-scratch",
        "PPO from scratch",
        "symrl baseline ppo --episodes {n} --seeds 100-104 --out results/baselines/ppo-scratch",
    ),
    (
        "ppo-residual",
        "PPO residual",
        "symrl baseline ppo --residual --episodes {n} "
        "--seeds 100-104 --out results/baselines/ppo-residual",
    ),
    (
        "ppo-residual+regions",
        "PPO residual + regions",
        "symrl baseline ppo --residual "
        "--regions --episodes {n} --seeds 100-104 --out results/baselines/ppo-residual+regions",
    ),
)
"""Folder under ``results/baselines``, label and command of each learner compared."""


def baseline_runs(folder: Path) -> list[dict[str, Any]]:
    """Per seed: its trial rows and, for a baseline, its wall times at 20 trials and at the end
    (a ``symrl baseline`` folder has ``seed-S/``, a ``symrl sweep`` folder ``runs/*/``)."""
    from symrl.runs import read_trials_csv

    data = _load(folder / "summary.json")
    timing = {}
    if data is not None and "runs" in data and data["runs"] and "at20" in data["runs"][0]:
        timing = {
            (r["seed"], r["end"]["trials"]): (r["at20"]["wall_time_s"], r["end"]["wall_time_s"])
            for r in data["runs"]
        }
    runs = []
    for csv in sorted(folder.glob("seed-*/trials.csv")) + sorted(folder.glob("runs/*/trials.csv")):
        seed = int(re.findall(r"\d+$", csv.parent.name)[0])  # seed-100, paper__MAP__s100
        rows = read_trials_csv(csv)
        wall = timing.get((seed, len(rows)))  # the summary's entry for this very run
        start, end = csv.parent / "config.yaml", csv.parent / "checkpoint.pt"
        if wall is None and start.is_file() and end.is_file():
            # no summary entry (a sweep's run, or a command stopped after this seed): from its
            # files, config.yaml written at the start and checkpoint.pt at the end
            span = round(end.stat().st_mtime - start.stat().st_mtime, 1)
            wall = (span if len(rows) <= 20 else None, span)
        runs.append({"seed": seed, "rows": rows, "wall": wall})
    return runs


def _mean_sd(values: list[float], digits: int = 1) -> str:
    import numpy as np

    if not values:
        return "-"
    v = np.asarray(values, dtype=float)
    return f"{v.mean():.{digits}f} ± {v.std(ddof=1) if len(v) > 1 else 0.0:.{digits}f}"


def _first(values: list[int | None]) -> str:
    hit = [v for v in values if v is not None]
    never = len(values) - len(hit)
    if not hit:
        return f"never ({never})"
    return f"{_mean_sd([float(v) for v in hit])} ({never})"


def baseline_table(results: Path) -> tuple[str, dict[str, list[list[dict[str, Any]]]]]:
    """The comparison table (every learner at 20 trials and at the end of its budget) and the
    trial tables per learner for the figure."""
    from symrl.studies.baseline import summarise

    lines = [
        "| learner | trials | seeds | first success (never) | first reliable, >= 80 % of 20 "
        "(never) | last-5 actions | last-5 total reinf. | collisions per run | env steps per run "
        "| wall time per run (s) |",
        "| --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    curves: dict[str, list[list[dict[str, Any]]]] = {}
    for name, label, _ in BASELINE_VARIANTS:
        runs = baseline_runs(results / name)
        if not runs:
            lines.append(f"| {label} | *not run* | | | | | | | | |")
            continue
        curves[label] = [r["rows"] for r in runs]
        lengths = [len(r["rows"]) for r in runs]
        # 20 trials, the budget every seed ran, and the longest (on the seeds that ran it)
        for n in sorted({min(20, min(lengths)), min(lengths), max(lengths)}):
            done = [r for r in runs if len(r["rows"]) >= n]
            s = [summarise(r["rows"], n) for r in done]
            walls = [
                r["wall"][0] if n == 20 else r["wall"][1] if len(r["rows"]) == n else None
                for r in done
                if r["wall"]
            ]
            lines.append(
                f"| {label} | {n} | {len(done)} | {_first([x['first_success'] for x in s])} "
                f"| {_first([x['first_reliable'] for x in s])} "
                f"| {_mean_sd([x['last5_actions'] for x in s])} "
                f"| {_mean_sd([x['last5_total'] for x in s], 2)} "
                f"| {_mean_sd([x['collisions'] for x in s])} "
                f"| {_mean_sd([x['env_steps'] for x in s], 0)} "
                f"| {_mean_sd([w for w in walls if w is not None]) if walls else '-'} |"
            )
    return "\n".join(lines) + "\n", curves


def baseline_blocks(results: Path, least: int = 200) -> str:
    """Has a long run levelled? Per learner that ran at least ``least`` trials: its mean path
    and total per block of trials (100, or 250 past 1,000 trials), mean ± sd over the seeds
    that ran the whole block."""
    lines = [
        "| learner | trials | seeds | mean actions | mean total reinf. |",
        "| --- | --- | ---: | ---: | ---: |",
    ]
    for name, label, _ in BASELINE_VARIANTS:
        runs = [r for r in baseline_runs(results / name) if len(r["rows"]) >= least]
        if not runs:
            continue
        longest = max(len(r["rows"]) for r in runs)
        size = 100 if longest <= 1000 else 250
        for lo in range(0, longest - size + 1, size):
            blocks = [r["rows"][lo : lo + size] for r in runs if len(r["rows"]) >= lo + size]
            actions = [sum(t["steps"] for t in b) / size for b in blocks]
            totals = [sum(t["total_reinforcement"] for t in b) / size for b in blocks]
            lines.append(
                f"| {label} | {lo + 1}-{lo + size} | {len(blocks)} "
                f"| {_mean_sd(actions)} | {_mean_sd(totals, 2)} |"
            )
    return "\n".join(lines) + "\n" if len(lines) > 2 else ""


BASELINE_NOTES = Path(__file__).with_name("baselines_discussion.md")
"""Hand-written reading of the baseline comparison (settings, budgets, who wins)."""


def _section_baselines(results: Path, figures: Path) -> list[str]:
    from symrl.figures import plot_learning_curves

    folder = results / "baselines"
    out = ["## Modern baselines given the same prior knowledge (`symrl baseline`)", ""]
    table, curves = baseline_table(folder)
    if not curves:
        return out + ["*Not run yet.*", ""]
    out += ["Commands (seeds 100-104, never tuned on; budgets as in the table):", ""]
    for name, label, command in BASELINE_VARIANTS:
        runs = baseline_runs(folder / name)
        if runs:
            for n in sorted({len(r["rows"]) for r in runs}):
                seeds = [r["seed"] for r in runs if len(r["rows"]) == n]
                text = command.format(n=n)
                if len(seeds) < len(runs):
                    text = text.replace("100-104", ",".join(map(str, seeds)))
                out.append(f"- {label}: `{text}`")
    out += ["", table]
    figures.mkdir(parents=True, exist_ok=True)
    plot_learning_curves(
        curves,
        folder / "comparison.png",
        "The paper's learner and SAC / PPO (TorchRL), seeds 100-104",
        optimum=25,
    )
    out += [_fig(folder / "comparison.png", figures, "baselines.png"), ""]
    blocks = baseline_blocks(folder)
    if blocks:
        out += [
            "Has a long run levelled? Mean path and total per block of trials (mean ± sd "
            "over the seeds that ran the whole block):",
            "",
            blocks,
        ]
    if BASELINE_NOTES.is_file():
        out += [BASELINE_NOTES.read_text(), ""]
    return out


def _section_generalise(results: Path, figures: Path) -> list[str]:
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
        data = _load(folder / "generalise.json")
        if data is None:
            out += ["*Not run yet.*", ""]
            continue
        out += [
            measured_at(data),
            "",
            (folder / "generalise.md").read_text(),
            f"Wall time {data['wall_time_s']} s.",
            "",
            _fig(folder / "starts.png", figures, f"generalise-{recipe}-starts.png"),
            "",
            _fig(folder / "obstacle.png", figures, f"generalise-{recipe}-obstacle.png"),
            "",
        ]
    return out


def _built_from() -> str:
    """The commit of the code this report was built with."""
    import subprocess

    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        head = "unknown"
    return f"Built with the code at commit `{head}`."


SECTIONS = (
    _section_plan,
    _section_table1,
    _section_ladder,
    _section_study,
    _section_ablate,
    _section_changes,
    _section_baselines,
    _section_generalise,
)
"""The report's sections, in order; each returns its Markdown lines, headed by ``## ``."""


def split_sections(text: str) -> dict[str, str]:
    """A RESULTS.md text as {``## `` heading line: the section's text up to the next one}."""
    parts = re.split(r"(?m)^(?=## )", text)
    return {part.splitlines()[0]: part for part in parts if part.startswith("## ")}


def carry_over(fresh: list[str], previous: dict[str, str]) -> list[str]:
    """``fresh`` (one section's lines), or the previous RESULTS.md's text of the same section
    when this build has no results for it and that text has some."""
    text = "\n".join(fresh)
    if not fresh or "*Not run yet.*" not in text:
        return fresh
    old = previous.get(fresh[0])
    if old is None or "*Not run yet.*" in old:
        return fresh
    head, _, body = old.partition("\n")
    body = body.lstrip("\n")
    if not body.startswith(NOT_RERUN):
        body = f"{NOT_RERUN}\n\n{body}"
    return [head, "", body.rstrip("\n"), ""]


def build(
    results: Path = Path("results"), figures: Path = Path("docs/figures"), previous: str = ""
) -> str:
    """The whole RESULTS.md text (copies figures as a side effect); ``previous`` is the
    RESULTS.md it replaces, whose sections stand in for those not re-run."""
    from symrl.studies.repeatability import PAPER_TABLE1 as paper

    old = split_sections(previous)
    lines = [
        "# Results",
        "",
        "<!-- Generated by `python -m symrl.studies.report`: edit the report or the "
        "discussion files in symrl/studies/, not this file. -->",
        "",
        "**Generated** by `python -m symrl.studies.report` from the folders the commands of "
        "each section wrote (`results/`, git-ignored); figures are copied to `docs/figures/`. "
        "Each section names its command and the commit its numbers were measured at. All runs: "
        "noise on, seeds 100-109 (set k uses seed 100 + k; never used for tuning), 2 CPU cores "
        "shared with other jobs, so wall times are upper bounds. The paper's numbers: Hailu "
        "(2001), Table 1 (real robot, 10 sets x 20 trials, last trial): "
        f"neurons {paper['neurons']['mean']} (var {paper['neurons']['variance']}), "
        f"steps {paper['steps']['mean']} (var {paper['steps']['variance']}), "
        f"total reinforcement {paper['total_reinforcement']['mean']} "
        f"(var {paper['total_reinforcement']['variance']}).",
        "",
        _built_from(),
        "",
    ]
    for section in SECTIONS:
        lines += carry_over(section(results, figures), old)
    if INTERPRETATION.is_file():
        lines += [INTERPRETATION.read_text()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Write RESULTS.md (``--out``) from ``--results``."""
    parser = argparse.ArgumentParser(prog="python -m symrl.studies.report", description=__doc__)
    parser.add_argument("--results", default="results")
    parser.add_argument("--figures", default="docs/figures")
    parser.add_argument("--out", default="RESULTS.md")
    parser.add_argument(
        "--only",
        choices=["baselines"],
        default=None,
        help="print one section only (RESULTS.md is left alone)",
    )
    args = parser.parse_args(argv)
    if args.only == "baselines":
        print("\n".join(_section_baselines(Path(args.results), Path(args.figures))))
        return 0
    out = Path(args.out)
    previous = out.read_text() if out.is_file() else ""
    text = build(Path(args.results), Path(args.figures), previous)
    out.write_text(text)
    print(f"wrote {args.out} ({len(text.splitlines())} lines), figures in {args.figures}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
