"""Statistics over a study's sets: the paper's Table 1, learning curves, per-recipe summaries
with bootstrap intervals, the other starts' successes, and the map's optimum for the tables."""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from symrl.studies.sets import SetResult

LAST = 5
"""Trials at the end of a set that its summary averages over."""


def last_trial_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The row of the last trial of every set (sets in increasing order)."""
    last: dict[int, dict[str, Any]] = {}
    for row in rows:
        s = int(row["set"])
        if s not in last or int(row["trial"]) > int(last[s]["trial"]):
            last[s] = row
    return [last[s] for s in sorted(last)]


TABLE_KEYS = (
    "neurons",
    "steps",
    "total_reinforcement",
    "collisions",
    "reached_goal",
    "path_length",
)
"""The columns of the paper's Table 1."""


def table1(rows: Sequence[dict[str, Any]], keys: Sequence[str] = TABLE_KEYS) -> dict[str, Any]:
    """Mean, sample variance (ddof 1), min and max over sets of each key at the last trial."""
    if not rows:
        raise ValueError("table1: no trial rows")
    last = last_trial_rows(rows)
    out: dict[str, Any] = {"sets": len(last), "trial": int(last[0]["trial"])}
    for key in keys:
        if key not in last[0]:
            continue
        v = np.array([float(r[key]) for r in last])
        out[key] = {
            "mean": float(v.mean()),
            "variance": float(v.var(ddof=1)) if len(v) > 1 else float("nan"),
            "min": float(v.min()),
            "max": float(v.max()),
        }
    return out


def curves(rows: Sequence[dict[str, Any]], key: str) -> np.ndarray:
    """(sets, trials) array of ``key`` (NaN where a set has fewer trials)."""
    sets = sorted({int(r["set"]) for r in rows})
    trials = sorted({int(r["trial"]) for r in rows})
    col = {t: j for j, t in enumerate(trials)}
    row = {s: i for i, s in enumerate(sets)}
    out = np.full((len(sets), len(trials)), np.nan)
    for r in rows:
        out[row[int(r["set"])], col[int(r["trial"])]] = float(r[key])
    return out


def mean_std(values: Sequence[float]) -> dict[str, Any]:
    """Mean and sample standard deviation, plus a 95 % bootstrap interval of the mean."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"mean": float("nan"), "std": float("nan"), "ci95": [float("nan")] * 2}
    rng = np.random.default_rng(0)  # fixed: the same rows give the same interval
    boot = rng.choice(v, size=(2000, v.size), replace=True).mean(axis=1)
    return {
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "ci95": [float(np.percentile(boot, 2.5)), float(np.percentile(boot, 97.5))],
    }


def summarise(rows: Sequence[dict[str, Any]], last: int = LAST) -> dict[str, Any]:
    """The summary of one recipe's sets: first success, success rate over the last ``last``
    trials, their mean actions and total reinforcement (per set, then mean, sd and a 95 %
    bootstrap interval over sets), neurons (a learner that has them) and collisions at the
    last trial, all collisions."""
    if not rows:
        raise ValueError("summarise: no trial rows")
    by_set: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_set.setdefault(int(r["set"]), []).append(r)
    never = 0
    firsts, success, steps, reinf, neurons, coll_last, coll_all = ([] for _ in range(7))
    opening: list[float] = []
    coll_tail = 0
    for s in sorted(by_set):
        trials = sorted(by_set[s], key=lambda r: int(r["trial"]))
        first = next((int(r["trial"]) for r in trials if bool(r["reached_goal"])), None)
        if first is None:
            never += 1
        else:
            firsts.append(first)
        tail = trials[-last:]
        success += [float(bool(r["reached_goal"])) for r in tail]
        steps.append(float(np.mean([float(r["steps"]) for r in tail])))
        reinf.append(float(np.mean([float(r["total_reinforcement"]) for r in tail])))
        if "neurons" in trials[-1]:  # the baselines grow no neurons
            neurons.append(float(trials[-1]["neurons"]))
        coll_last.append(float(trials[-1]["collisions"]))
        coll_all.append(sum(float(r["collisions"]) for r in trials))
        coll_tail += int(sum(float(r["collisions"]) for r in tail))
        opening.append(float(trials[0]["total_reinforcement"]))
    out = {
        "sets": len(by_set),
        "trials": max(int(r["trial"]) for r in rows),
        "first_success": {**mean_std(firsts), "never": never},
        f"success_last{last}": float(np.mean(success)),
        f"steps_last{last}": mean_std(steps),
        f"total_reinforcement_last{last}": mean_std(reinf),
        "neurons_last": mean_std(neurons),
        "collisions_last": mean_std(coll_last),
        "collisions_all_trials": mean_std(coll_all),
        f"collisions_last{last}_sum": coll_tail,
        "total_reinforcement_first": mean_std(opening),
    }
    if not neurons:
        del out["neurons_last"]
    return out


def start_summary(results: Sequence[SetResult]) -> list[dict[str, Any]]:
    """Per other start pose: how many sets' final controllers reached the goal from it."""
    out = []
    for k in range(len(results[0].evaluations) if results else 0):
        evs = [r.evaluations[k] for r in results]
        out.append(
            {
                "start": evs[0]["start"],
                "reached": sum(e["reached_goal"] for e in evs),
                "sets": len(evs),
                "mean_steps_when_reached": (
                    float(np.mean([e["steps"] for e in evs if e["reached_goal"]]))
                    if any(e["reached_goal"] for e in evs)
                    else None
                ),
            }
        )
    return out


@functools.lru_cache(maxsize=8)
def _optimum(map_name: str) -> tuple[int, float]:
    from symrl.knowledge.planner import shortest_path
    from symrl.world import load_map

    plan = shortest_path(load_map(map_name))
    return plan.actions, round(plan.length, 3)


def optimum(map_name: str = "hailu2001") -> dict[str, Any]:
    """The shortest path of a map (``symrl plan``), for the tables (computed once per map)."""
    t0 = time.perf_counter()
    steps, length = _optimum(map_name)
    return {"steps": steps, "length_m": length, "seconds": round(time.perf_counter() - t0, 2)}
