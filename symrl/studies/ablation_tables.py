"""The ablation's Markdown tables: one row per recipe (``summary.md``), per setting put back
(``changes.md``) and per rung of knowledge (``ladder.md``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from symrl.studies.ablation_variants import LADDER, Variant
from symrl.studies.repeatability import PAPER_TABLE1
from symrl.studies.stats import LAST, curves


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
