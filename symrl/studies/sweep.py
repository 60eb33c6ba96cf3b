"""``symrl sweep``: a grid of runs (recipes x seeds x maps, the same overrides for all), each a
normal run folder, then one merged table and one figure.

Every run is written by :func:`symrl.studies.learners.run_recipe`, the code path of ``symrl
train`` (the paper's learner or a baseline recipe), into
``OUT/runs/<recipe>__<map>__s<seed>/``: its ``trials.csv`` is the one ``symrl train RECIPE
--seed SEED --map MAP`` writes alone. A run folder that already holds the finished run (its
config and the full number of trials) is kept, not run again, so a stopped sweep re-run into
the same ``--out`` does only what is missing. The runs go to a local process pool
(``--backend local``) or to Ray tasks (``--backend ray``, ``pip install "symrl[ray]"``); each run
is seeded by its own config, so both give the same tables.

``OUT/summary.md`` and ``OUT/summary.json`` hold, per recipe and map, the statistics over seeds
of :func:`symrl.studies.runner.summarise`; ``OUT/comparison.png`` the recipes' mean curves, one
row per map.
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["SweepRun", "parse_seeds", "plan_sweep", "run_sweep", "sweep_command", "BACKENDS"]

BACKENDS = ("local", "ray")
RAY_MISSING = 'the ray backend needs Ray: pip install "symrl[ray]"'
QUANTITIES = ("steps", "total_reinforcement", "collisions")


@dataclass(frozen=True)
class SweepRun:
    """One cell of the grid: its recipe, map, seed, resolved config (as a dict) and folder."""

    recipe: str
    map: str
    seed: int
    config: dict[str, Any]
    logdir: str


MAX_RUNS = 10_000
"""Most runs (recipes x seeds x maps) one sweep trains."""


def parse_seeds(text: str) -> list[int]:
    """``100-102``, ``100,105``, ``7`` or a mix (``1-3,9``) as a sorted list of seeds >= 0."""
    seeds: set[int] = set()
    for part in (p.strip() for p in str(text).split(",")):
        try:
            if "-" in part:
                lo_text, hi_text = part.split("-", 1)
                lo, hi = int(lo_text), int(hi_text)
            else:
                lo = hi = int(part)
        except ValueError:
            raise ValueError(
                f"--seeds {text!r}: expected seeds and ranges like 100-102 or 100,101"
            ) from None
        if lo < 0 or hi < lo:
            raise ValueError(f"--seeds {text!r}: range {part!r} is empty or negative")
        if hi >= 2**63:
            raise ValueError(f"--seeds {text!r}: seeds must be below 2**63")
        if hi - lo + 1 + len(seeds) > MAX_RUNS:  # counted before the range is spelled out
            raise ValueError(
                f"--seeds {text!r}: more than {MAX_RUNS} seeds; a sweep runs at "
                f"most {MAX_RUNS} runs"
            )
        seeds.update(range(lo, hi + 1))
    return sorted(seeds)


def _names(text: str, flag: str) -> list[str]:
    names = [n.strip() for n in str(text).split(",") if n.strip()]
    if not names:
        raise ValueError(f"{flag} {text!r}: no names given")
    return list(dict.fromkeys(names))


def _map_label(name: str) -> str:
    """A map name fit for a folder name (a map file becomes its stem)."""
    return Path(name).stem if Path(name).suffix else name


def plan_sweep(
    recipes: Sequence[str],
    seeds: Sequence[int],
    maps: Sequence[str],
    trials: int,
    out: str | os.PathLike[str],
    overrides: Sequence[str] = (),
) -> list[SweepRun]:
    """The grid, recipes outermost, then maps, then seeds; every recipe, map and override is
    checked here (one-line errors) before any run starts."""
    from symrl.learner.config import config_to_dict, load_config
    from symrl.world.worldmap import load_map

    if trials < 1:
        raise ValueError(f"--trials {trials}: must be >= 1")
    if not recipes or not seeds or not maps:
        raise ValueError("empty grid: give at least one recipe, one seed and one map")
    runs = len(recipes) * len(seeds) * len(maps)
    if runs > MAX_RUNS:
        raise ValueError(
            f"the grid has {runs} runs ({len(recipes)} recipes x {len(seeds)} seeds "
            f"x {len(maps)} maps), more than the {MAX_RUNS} a sweep runs"
        )
    for name in maps:
        load_map(name)
    grid = []
    for recipe in recipes:
        for name in maps:
            for seed in seeds:
                config = load_config(
                    recipe,
                    [*overrides, f"run.trials={trials}", f"run.seed={seed}", f"env.map={name}"],
                )
                folder = Path(out) / "runs" / f"{config.recipe}__{_map_label(name)}__s{seed}"
                grid.append(
                    SweepRun(config.recipe, name, int(seed), config_to_dict(config), str(folder))
                )
    folders = [r.logdir for r in grid]
    if len(set(folders)) < len(folders):
        same = next(f for f in folders if folders.count(f) > 1)
        raise ValueError(
            f"two runs of the grid would share the folder {same!r} "
            "(recipes or maps with the same name)"
        )
    return grid


def _is_done(run: SweepRun) -> bool:
    """The folder holds this run, finished: its config and every trial."""
    import yaml

    from symrl.runs import finished_trials

    folder = Path(run.logdir)
    if finished_trials(folder) < int(run.config["run"]["trials"]):
        return False
    try:
        saved = yaml.safe_load((folder / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return False
    if not isinstance(saved, dict):
        return False
    saved.pop("provenance", None)
    from symrl.learner.config import config_from_dict
    from symrl.learner.config.baselines import used_settings

    recorded = used_settings(config_from_dict(run.config), run.config)  # what config.yaml holds
    return bool(saved == yaml.safe_load(yaml.safe_dump(recorded, sort_keys=False)))


def train_run(config: dict[str, Any], logdir: str, resume: bool = False) -> list[dict[str, Any]]:
    """Train one run of the grid into ``logdir`` (replacing an unfinished one, or with
    ``resume`` going on from its last checkpoint when it is a stopped run of this config); its
    trial rows as written to ``trials.csv``. Runs in a worker process or a Ray task."""
    import torch

    from symrl.learner.config import config_from_dict
    from symrl.runs import read_trials_csv
    from symrl.studies.learners import run_recipe

    torch.set_num_threads(1)
    cfg = config_from_dict(config, recipe=str(config.get("recipe", "sweep")))
    state = _stopped_state(cfg, logdir) if resume else None
    if state is not None:
        run_recipe(cfg, logdir, resume=state, seed=cfg.run.seed, progress=False)
    else:
        run_recipe(cfg, logdir, overwrite=True, progress=False)
    return read_trials_csv(Path(logdir) / "trials.csv")


def _stopped_state(config: Any, logdir: str) -> dict[str, Any] | None:
    """The run state of a stopped run of ``config`` in ``logdir`` (None: nothing to go on
    with there: no run, another config, or a checkpoint without run state)."""
    from symrl.learner.config import config_to_dict
    from symrl.runs import CheckpointError
    from symrl.studies.learners import load_run

    if not (Path(logdir) / "checkpoint.pt").is_file():
        return None
    try:
        saved, seed, state, _ = load_run(logdir)
    except (CheckpointError, ValueError, OSError):
        return None
    same = config_to_dict(saved) == config_to_dict(config) and seed == config.run.seed
    if not same or len(state["trials"]) >= config.run.trials:
        return None
    return state


def _run_ray(jobs: list[dict[str, Any]], workers: int | None) -> list[Any]:
    try:
        import ray
    except ImportError:
        raise ValueError(RAY_MISSING) from None
    started = not ray.is_initialized()
    if started:
        path = os.pathsep.join(p for p in (os.getcwd(), os.environ.get("PYTHONPATH")) if p)
        ray.init(
            num_cpus=workers,
            include_dashboard=False,
            log_to_driver=False,
            runtime_env={"env_vars": {"PYTHONPATH": path}},
        )
    try:
        task = ray.remote(num_cpus=1)(train_run)
        return list(
            ray.get(
                [
                    task.remote(job["config"], job["logdir"], job.get("resume", False))
                    for job in jobs
                ]
            )
        )
    finally:
        if started:
            ray.shutdown()


def run_sweep(
    grid: Sequence[SweepRun],
    workers: int | None = 1,
    backend: str = "local",
    resume: bool = False,
) -> dict[str, Any]:
    """Train every run of ``grid`` not finished yet, on ``backend``; returns ``{"ran": n,
    "kept": n, "rows": {logdir: trial rows}}``."""
    from symrl.runs import read_trials_csv
    from symrl.studies.runner import run_jobs

    if backend not in BACKENDS:
        raise ValueError(f"--backend {backend!r}: expected one of {', '.join(BACKENDS)}")
    if workers is not None and workers < 1:
        raise ValueError(f"--workers {workers}: must be >= 1")
    todo = [r for r in grid if not _is_done(r)]
    jobs = [
        {"config": r.config, "logdir": r.logdir, **({"resume": True} if resume else {})}
        for r in todo
    ]
    if backend == "ray":
        results = _run_ray(jobs, workers) if jobs else []
    else:
        results = run_jobs(train_run, jobs, workers or 1, desc="sweep") if jobs else []
    rows = {r.logdir: rs for r, rs in zip(todo, results, strict=True)}
    for r in grid:
        if r.logdir not in rows:
            rows[r.logdir] = read_trials_csv(Path(r.logdir) / "trials.csv")
    return {"ran": len(todo), "kept": len(grid) - len(todo), "rows": rows}


def _fmt_stat(stat: dict[str, Any], digits: int = 2) -> str:
    mean, sd, (lo, hi), d = stat["mean"], stat["std"], stat["ci95"], digits
    return f"{mean:.{d}f} ± {sd:.{d}f} [{lo:.{d}f}, {hi:.{d}f}]"


def summary_tables(
    grid: Sequence[SweepRun], rows: dict[str, list[dict[str, Any]]]
) -> tuple[list[dict[str, Any]], str, dict[str, dict[str, dict[str, np.ndarray]]]]:
    """Per recipe x map the :func:`summarise` over its seeds; the Markdown table; the curves
    (``curves[map][recipe][quantity]``, seeds x trials) for the figure."""
    from symrl.studies.runner import LAST, curves, summarise

    cells: dict[tuple[str, str], list[SweepRun]] = {}
    for r in grid:
        cells.setdefault((r.recipe, r.map), []).append(r)
    results: list[dict[str, Any]] = []
    figure: dict[str, dict[str, dict[str, np.ndarray]]] = {}
    for (recipe, name), runs in cells.items():
        merged = [{**row, "set": r.seed, "seed": r.seed} for r in runs for row in rows[r.logdir]]
        results.append(
            {"recipe": recipe, "map": name, "seeds": [r.seed for r in runs], **summarise(merged)}
        )
        figure.setdefault(name, {})[recipe] = {q: curves(merged, q) for q in QUANTITIES}
    lines = [
        f"| recipe | map | seeds | trials | last-{LAST} actions | last-{LAST} total "
        f"reinforcement (mean ± sd [95 % CI]) | collisions, all trials | success, last {LAST} "
        "| first success (never) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for s in results:
        first = s["first_success"]
        first_text = "–" if np.isnan(first["mean"]) else f"{first['mean']:.1f}"
        lines.append(
            f"| {s['recipe']} | {s['map']} | {s['sets']} | {s['trials']} "
            f"| {_fmt_stat(s[f'steps_last{LAST}'], 1)} "
            f"| {_fmt_stat(s[f'total_reinforcement_last{LAST}'])} "
            f"| {_fmt_stat(s['collisions_all_trials'], 1)} "
            f"| {s[f'success_last{LAST}']:.0%} | {first_text} ({first['never']}) |"
        )
    return results, "\n".join(lines) + "\n", figure


def write_summary(
    out: str | os.PathLike[str],
    grid: Sequence[SweepRun],
    rows: dict[str, list[dict[str, Any]]],
    settings: dict[str, Any],
) -> str:
    """Write ``summary.md``, ``summary.json`` and ``comparison.png`` into ``out``; returns the
    Markdown table."""
    from symrl.figures import plot_map_comparison

    out = Path(out)
    results, table, figure = summary_tables(grid, rows)
    (out / "summary.md").write_text(
        "# Sweep\n\n"
        f"recipes {', '.join(settings['recipes'])}; maps {', '.join(settings['maps'])}; "
        f"seeds {', '.join(str(s) for s in settings['seeds'])}; {settings['trials']} trials"
        + (f"; overrides {' '.join(settings['overrides'])}" if settings["overrides"] else "")
        + ". Statistics over seeds (one run per seed); runs in `runs/`.\n\n"
        + table
    )
    data = {
        "settings": settings,
        "runs": [
            {"recipe": r.recipe, "map": r.map, "seed": r.seed, "logdir": r.logdir} for r in grid
        ],
        "results": results,
    }
    (out / "summary.json").write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    plot_map_comparison(figure, out / "comparison.png", QUANTITIES)
    return table


def sweep_command(args: argparse.Namespace) -> int:
    """The ``symrl sweep`` handler."""
    recipes = _names(args.recipes, "--recipes")
    maps = _names(args.maps, "--maps")
    seeds = parse_seeds(args.seeds)
    overrides = list(args.overrides or [])
    if args.backend not in BACKENDS:
        raise ValueError(f"--backend {args.backend!r}: expected one of {', '.join(BACKENDS)}")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers {args.workers}: must be >= 1")
    if args.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ValueError(RAY_MISSING) from None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {args.out!r}: exists and is not a folder")
    grid = plan_sweep(recipes, seeds, maps, args.trials, out, overrides)
    out.mkdir(parents=True, exist_ok=True)
    from symrl.studies import checkpointing

    resume = bool(getattr(args, "resume", False))
    marked = {
        "recipes": recipes,
        "maps": maps,
        "seeds": seeds,
        "trials": args.trials,
        "overrides": overrides,
    }
    with checkpointing.running(out, "sweep", marked, resume):
        done = run_sweep(grid, workers=args.workers, backend=args.backend, resume=resume)
    settings = {
        "recipes": recipes,
        "maps": maps,
        "seeds": seeds,
        "trials": args.trials,
        "overrides": overrides,
        "backend": args.backend,
    }
    table = write_summary(out, grid, done["rows"], settings)
    print(table, end="")
    print(
        f"{len(grid)} runs ({done['ran']} trained, {done['kept']} already finished); "
        f"wrote {out}/ (summary.md, summary.json, comparison.png, runs/)"
    )
    return 0
