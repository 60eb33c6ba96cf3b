"""`symrl study RECIPE`: the paper's repeatability study (N sets x M trials, Table 1, Figs 5-9).

Each set is one independent training run of the recipe with seed ``seed + k``; sets run in
parallel worker processes (one torch thread each). The study writes one results folder:

- ``trials.csv``: one row per (set, trial) with every scalar the trainer reports
- ``table1.md`` / ``table1.json``: mean and variance at the last trial beside the paper's Table 1
  and the optimum of ``symrl plan``
- ``curves.png`` (Figs 7-9), ``trajectories.png`` (Fig 6), ``ghosts.png`` (Fig 5)

Variances are sample variances (ddof = 1) over the sets; the paper does not say which it used.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

__all__ = [
    "PAPER_TABLE1",
    "OTHER_STARTS",
    "SetResult",
    "StudyResult",
    "run_set",
    "run_sets",
    "run_study",
    "table1",
    "write_trials_csv",
    "read_trials_csv",
    "study_command",
]

PAPER_TABLE1 = {
    "neurons": {"mean": 82.5, "variance": 4.7286},
    "steps": {"mean": 27.7, "variance": 1.9000},
    "total_reinforcement": {"mean": -6.24, "variance": 0.8752},
}
"""Hailu (2001), Table 1: real robot, 10 sets x 20 trials, at the last trial."""

OTHER_STARTS: tuple[tuple[float, float, float], ...] = (
    (-1.0, 1.5, 0.0),
    (1.0, -1.8, 0.0),
    (2.0, 1.5, -math.pi / 2),
    (-0.8, -1.0, math.pi / 4),
)
"""Four start poses in the room for the final controller (Fig. 5 bottom right)."""

TABLE_KEYS = (
    "neurons", "steps", "total_reinforcement", "collisions", "reached_goal", "path_length"
)
_SKIP = {"path", "ghosts", "odometry_path"}


@dataclass
class SetResult:
    """One set (one training run): its trial rows plus the paths the figures need."""

    index: int
    seed: int
    rows: list[dict[str, Any]]
    paths: dict[int, list[list[float]]] = field(default_factory=dict)
    """Trial number -> true path, for the first, first successful and final trials."""
    ghosts: dict[int, list[list[float]]] = field(default_factory=dict)
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    """Greedy runs of the final controller from other start poses (with their paths)."""
    wall_time: float = 0.0


@dataclass
class StudyResult:
    """Every set of a study, in set order, and where its files went."""

    recipe: str
    sets: list[SetResult]
    table: dict[str, Any]
    out: Path | None
    wall_time: float

    @property
    def rows(self) -> list[dict[str, Any]]:
        """All trial rows of all sets, set-major."""
        return [row for s in self.sets for row in s.rows]


# --- one set (runs in a worker process) --------------------------------------------------------


def _scalar(value: Any) -> Any:
    """numpy / torch scalars to plain Python numbers for csv and json."""
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        return value.item()
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    return value


def _xy(path: Any) -> list[list[float]]:
    return np.asarray(path, dtype=float).reshape(-1, 2).round(4).tolist()


def run_set(
    recipe: str,
    index: int,
    seed: int,
    trials: int,
    overrides: Sequence[str] = (),
    starts: Sequence[tuple[float, float, float]] = OTHER_STARTS,
) -> SetResult:
    """Train ``recipe`` for ``trials`` trials with ``seed`` and drive the result from ``starts``."""
    import torch

    from symrl.learner.config import load_config
    from symrl.train import evaluate, train

    torch.set_num_threads(1)
    t0 = time.perf_counter()
    config = load_config(recipe, [*overrides, f"run.trials={trials}", f"run.seed={seed}"])
    result = train(config, logdir=None, progress=False)
    rows, paths, ghosts = [], {}, {}
    first_success = next((t["trial"] for t in result.trials if bool(t["reached_goal"])), None)
    keep = {result.trials[0]["trial"], result.trials[-1]["trial"], first_success}
    for t in result.trials:
        row = {"set": index, "seed": seed}
        row.update({k: _scalar(v) for k, v in t.items() if k not in _SKIP})
        rows.append(row)
        if t["trial"] in keep:
            paths[int(t["trial"])] = _xy(t.get("path", []))
            ghosts[int(t["trial"])] = _xy(t.get("ghosts", []))
    evaluations = []
    for k, start in enumerate(starts):
        ev = evaluate(result.policy, start=tuple(start), seed=seed + 1000 * (k + 1), noise=True)
        evaluations.append(
            {
                "start": list(start),
                "reached_goal": bool(ev["reached_goal"]),
                "steps": int(ev["steps"]),
                "collisions": int(ev["collisions"]),
                "total_reinforcement": float(ev["total_reinforcement"]),
                "path": _xy(ev.get("path", [])),
            }
        )
    return SetResult(index, seed, rows, paths, ghosts, evaluations, time.perf_counter() - t0)


def _init_worker() -> None:
    import torch

    torch.set_num_threads(1)


def run_sets(
    jobs: Sequence[dict[str, Any]],
    workers: int | None = None,
    desc: str = "sets",
    fn: Callable[..., Any] = run_set,
) -> list[Any]:
    """Run ``fn(**job)`` for every job, in ``workers`` processes (1: in this process), in order."""
    workers = max(1, min(workers or os.cpu_count() or 1, len(jobs)))
    results: list[Any] = [None] * len(jobs)
    bar = tqdm(total=len(jobs), desc=desc, unit="set")
    if workers == 1:
        for i, job in enumerate(jobs):
            results[i] = fn(**job)
            bar.update()
    else:
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")  # no forked torch / OpenMP state
        with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init_worker) as pool:
            futures = {pool.submit(fn, **job): i for i, job in enumerate(jobs)}
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                bar.update()
    bar.close()
    return results


# --- statistics --------------------------------------------------------------------------------


def last_trial_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The row of the last trial of every set (sets in increasing order)."""
    last: dict[int, dict[str, Any]] = {}
    for row in rows:
        s = int(row["set"])
        if s not in last or int(row["trial"]) > int(last[s]["trial"]):
            last[s] = row
    return [last[s] for s in sorted(last)]


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


def write_trials_csv(rows: Sequence[dict[str, Any]], path: Path) -> None:
    """One row per (set, trial); columns in first-seen order."""
    columns: list[str] = []
    for r in rows:
        columns += [k for k in r if k not in columns]
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def read_trials_csv(path: Path | str) -> list[dict[str, Any]]:
    """Read ``trials.csv`` back with numbers as floats (``True``/``False`` as 1/0)."""

    def num(v: str) -> Any:
        if v in ("True", "False"):
            return float(v == "True")
        try:
            return float(v)
        except ValueError:
            return v

    with open(path, newline="") as fh:
        return [{k: num(v) for k, v in r.items()} for r in csv.DictReader(fh)]


def code_version() -> str:
    """The code the numbers come from: the installed symrl's commit (``+dirty`` if it was built
    from a tree with uncommitted changes), else its version; see :func:`symrl.provenance`."""
    from symrl.about import provenance

    info = provenance()
    if info["revision"]:
        return info["revision"] + ("+dirty" if info["dirty"] else "")
    return info["symrl"] or "unknown"


@functools.lru_cache(maxsize=1)
def _optimum() -> tuple[int, float]:
    from symrl.studies.planner import shortest_path
    from symrl.world import load_map

    plan = shortest_path(load_map("hailu2001"))
    return plan.actions, round(plan.length, 3)


def optimum() -> dict[str, Any]:
    """The shortest path of the paper's world (``symrl plan``), for the tables (computed once)."""
    steps, length = _optimum()
    return {"steps": steps, "length_m": length}


def table1_markdown(recipe: str, table: dict[str, Any], opt: dict[str, Any] | None) -> str:
    """Table 1 beside the paper's numbers and the optimum, as Markdown."""
    lines = [
        f"Table 1 - `{recipe}`: {table['sets']} sets, last trial ({table['trial']}); "
        "variance = sample variance over sets",
        "",
        "| quantity | ours mean | ours variance | ours min-max | paper mean | paper variance "
        "| optimum |",
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


# --- the study ---------------------------------------------------------------------------------


def run_study(
    recipe: str,
    sets: int = 10,
    trials: int = 20,
    seed: int = 100,
    workers: int | None = None,
    overrides: Sequence[str] = (),
    out: Path | str | None = None,
    figures: bool = True,
    starts: Sequence[tuple[float, float, float]] = OTHER_STARTS,
) -> StudyResult:
    """Run ``sets`` sets of ``trials`` trials (set k: seed + k) and write the results folder."""
    if sets < 1 or trials < 1:
        raise ValueError(f"need at least 1 set and 1 trial, got sets={sets}, trials={trials}")
    t0 = time.perf_counter()
    jobs = [
        {"recipe": recipe, "index": k, "seed": seed + k, "trials": trials,
         "overrides": list(overrides), "starts": list(starts)}
        for k in range(sets)
    ]
    results: list[SetResult] = run_sets(jobs, workers, desc=f"study {recipe}")
    rows = [r for s in results for r in s.rows]
    table = table1(rows)
    opt = optimum()
    table["paper"] = PAPER_TABLE1
    table["optimum"] = opt
    table["recipe"] = recipe
    table["code"] = code_version()
    table["seeds"] = [seed, seed + sets - 1]
    table["overrides"] = list(overrides)
    table["other_starts"] = _start_summary(results)
    wall = time.perf_counter() - t0
    table["wall_time_s"] = round(wall, 1)
    study = StudyResult(recipe, results, table, Path(out) if out else None, wall)
    if out is not None:
        write_study(study, figures=figures)
    return study


def _start_summary(results: Sequence[SetResult]) -> list[dict[str, Any]]:
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


def write_study(study: StudyResult, figures: bool = True) -> None:
    """trials.csv, table1.md/json and the figures of a finished study."""
    out = study.out
    assert out is not None
    out.mkdir(parents=True, exist_ok=True)
    write_trials_csv(study.rows, out / "trials.csv")
    (out / "table1.json").write_text(json.dumps(study.table, indent=2) + "\n")
    md = table1_markdown(study.recipe, study.table, study.table.get("optimum"))
    starts = study.table.get("other_starts", [])
    if starts:
        md += "\nFinal controller (greedy) from other start poses: " + "; ".join(
            f"({s['start'][0]:g}, {s['start'][1]:g}) {s['reached']}/{s['sets']}" for s in starts
        ) + "\n"
    (out / "table1.md").write_text(md)
    if figures:
        write_figures(study)


def write_figures(study: StudyResult) -> None:
    """Figs 5-9 of the paper for this study."""
    from symrl.studies import figures as F
    from symrl.world import load_map

    out = study.out
    assert out is not None
    rows = study.rows
    world = load_map("hailu2001")
    ref = {
        "neurons:paper 82.5": 82.5,
        "steps:paper 27.7": 27.7,
        "total_reinforcement:paper -6.24": -6.24,
    }
    opt = study.table.get("optimum")
    if opt:
        ref[f"steps:optimum {opt['steps']}"] = opt["steps"]
    F.plot_curves(
        {k: curves(rows, k) for k in ("neurons", "steps", "total_reinforcement")},
        out / "curves.png",
        reference=ref,
        title=f"{study.recipe}: mean over {len(study.sets)} sets, bars min-max (Figs 7-9)",
    )
    s0 = study.sets[0]
    trials = sorted(s0.paths)
    first, last = trials[0], trials[-1]
    F.plot_paths(
        world,
        [
            (f"set 0, trial {first} (first)", [s0.paths[first]], []),
            (f"set 0, trial {last} (final)", [s0.paths[last]], []),
        ],
        out / "trajectories.png",
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
    F.plot_paths(world, panels, out / "ghosts.png", columns=2)


def study_command(args: argparse.Namespace) -> int:
    """`symrl study RECIPE`: run the study, print Table 1 and the wall time."""
    out = Path(args.out or f"results/study-{Path(args.recipe).stem}")
    study = run_study(
        args.recipe,
        sets=args.sets,
        trials=args.trials,
        seed=args.seed,
        workers=args.workers,
        overrides=args.overrides,
        out=out,
    )
    print((out / "table1.md").read_text())
    print(f"wrote {out}/ (trials.csv, table1.md, table1.json, curves.png, trajectories.png, "
          f"ghosts.png); wall time {study.wall_time:.1f} s")
    return 0
