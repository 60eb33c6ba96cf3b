"""RESULTS.md's section of the modern baselines (SAC, PPO) beside the paper's learner: the
learners compared, their runs read back, the comparison table and the long runs' blocks."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from symrl.studies.report_files import copy_figure, load_json

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

    data = load_json(folder / "summary.json")
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


def section_baselines(results: Path, figures: Path) -> list[str]:
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
    out += [copy_figure(folder / "comparison.png", figures, "baselines.png"), ""]
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
