"""``symrl baseline ALGO``: one baseline run folder per seed (:func:`symrl.studies.baseline.
train_baseline`, in worker processes or, stoppable by a signal, one after the other), then the
summary table, ``summary.json`` and the learning curves."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from symrl.studies.baseline import (
    baseline_settings,
    knowledge_of,
    load_run_state,
    parse_seeds,
    run_config,
    train_baseline,
)
from symrl.studies.baseline_agent import algorithms
from symrl.studies.priors import Priors

__all__ = ["baseline_command", "summary_markdown", "MAX_ENVS"]

MAX_ENVS = 1024
"""Most robots a baseline steps together (``--envs``): each holds its own world and buffers."""


def _run_settings(args: argparse.Namespace, priors: Priors, seed: int) -> dict[str, Any]:
    """The settings of the run of ``args`` for ``seed``."""
    cfg = algorithms()[args.algorithm][1]()
    return baseline_settings(
        args.algorithm, priors, seed, cfg.envs if args.envs is None else args.envs, cfg
    )


def summary_markdown(results: list[dict[str, Any]]) -> str:
    """One row per seed and budget."""
    lines = [
        "| seed | trials | first success | first reliable (>= 80% of 20) | successes "
        "| last-5 actions | last-5 total reinf. | collisions | env steps | wall time (s) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in results:
        for part in ("at20", "end") if r["end"]["trials"] > 20 else ("end",):
            s = r[part]
            lines.append(
                f"| {r['seed']} | {s['trials']} | {s['first_success'] or 'never'} "
                f"| {s['first_reliable'] or 'never'} | {s['successes']} "
                f"| {s['last5_actions']:.1f} | {s['last5_total']:.2f} | {s['collisions']} "
                f"| {s['env_steps']} | {s['wall_time_s']} |"
            )
    return "\n".join(lines) + "\n"


def baseline_command(args: argparse.Namespace, signalled: list[int] | None = None) -> int:
    """``symrl baseline ALGO``: one run folder per seed (``OUT/seed-S``), a summary table.
    ``signalled`` (one worker): the signals received; the first stops the run between two steps
    with its state saved (``--resume`` goes on)."""

    seeds = parse_seeds(args.seeds)
    if args.episodes < 1:
        raise ValueError(f"--episodes {args.episodes}: must be >= 1")
    if args.envs is not None and not 1 <= args.envs <= MAX_ENVS:
        raise ValueError(f"--envs {args.envs}: must be within 1..{MAX_ENVS}")
    if args.correction is not None and not args.residual:
        raise ValueError(
            f"--correction {args.correction:g}: only with --residual (it bounds "
            "the residual's correction; without --residual it would be ignored)"
        )
    if args.workers < 1:
        raise ValueError(f"--workers {args.workers}: must be >= 1")
    if args.checkpoint_every < 1:
        raise ValueError(f"--checkpoint-every {args.checkpoint_every}: must be >= 1")
    if args.resume and args.overwrite:
        raise ValueError(
            "--resume goes on with the runs in --out, --overwrite replaces them: give one"
        )
    priors = Priors(
        residual=args.residual,
        regions=args.regions,
        correction=0.25 if args.correction is None else args.correction,
    )
    out = Path(args.out or f"results/baseline-{args.algorithm}-{priors.label()}")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r}: exists and is not a folder")
    runs = [out / f"seed-{s}" for s in seeds]
    resumed = [args.resume and (run / "checkpoint.pt").is_file() for run in runs]
    for run, goes_on in zip(runs, resumed, strict=True):
        if (run / "config.yaml").exists() and not (args.overwrite or goes_on):
            hint = (
                "it has no checkpoint.pt to go on from"
                if args.resume
                else "pass --overwrite to replace it, or --resume to go on with it"
            )
            raise FileExistsError(f"--out {str(out)!r}: {run.name} already holds a run ({hint})")
    for run, goes_on, seed in zip(runs, resumed, seeds, strict=True):
        if goes_on:  # every run's settings are checked before any of them trains
            load_run_state(
                run,
                _run_settings(args, priors, seed),
                args.episodes,
                knowledge_of(run_config(args.map, seed, args.episodes), priors),
            )
    from symrl.locks import holding

    with holding(out, "--out"):
        return _baseline_runs(args, signalled, seeds, priors, out, runs, resumed)


def _baseline_runs(
    args: argparse.Namespace,
    signalled: list[int] | None,
    seeds: list[int],
    priors: Priors,
    out: Path,
    runs: list[Path],
    resumed: list[bool],
) -> int:
    """The runs of ``symrl baseline`` once its inputs are checked (``out`` locked)."""
    from symrl.studies.runner import run_jobs

    t0 = time.perf_counter()
    stop = (lambda: bool(signalled)) if signalled is not None else None
    jobs = [
        {
            "algorithm": args.algorithm,
            "seed": s,
            "episodes": args.episodes,
            "priors": priors,
            "map": args.map,
            "envs": args.envs,
            "logdir": str(run),
            "overwrite": args.overwrite,
            "resume": goes_on,
            "checkpoint_every": args.checkpoint_every,
            **({"stop": stop} if stop else {}),
        }
        for s, run, goes_on in zip(seeds, runs, resumed, strict=True)
    ]
    if stop is None:
        results = run_jobs(
            train_baseline, jobs, workers=args.workers, desc=f"{args.algorithm} {priors.label()}"
        )
    else:  # one worker: here, seed after seed, until a signal stops the current run
        results = []
        for job in jobs:
            if signalled:
                break
            results.append(train_baseline(**job))
    if signalled:
        import signal

        where = "before its first run"
        if results:
            last = results[-1]
            where = (
                f"after {len(last['rows'])} of {args.episodes} trials of seed "
                f"{last['seed']} (its state is saved in {out}/seed-{last['seed']}/)"
            )
        print(
            f"symrl baseline: stopped by {signal.Signals(signalled[0]).name} {where}; go "
            "on with the same command and --resume",
            file=sys.stderr,
        )
        return 128 + int(signalled[0])
    wall = round(time.perf_counter() - t0, 1)
    summary = [{k: v for k, v in r.items() if k != "rows"} for r in results]
    before = out / "summary.json"  # runs of other seeds in the same folder are kept
    if before.is_file():
        kept = [
            r for r in json.loads(before.read_text()).get("runs", []) if r.get("seed") not in seeds
        ]
        summary = sorted(kept + summary, key=lambda r: r["seed"])
    (out / "summary.json").write_text(json.dumps({"runs": summary, "wall_time_s": wall}, indent=2))
    md = summary_markdown(results)
    (out / "summary.md").write_text(md)
    from symrl.figures import plot_baseline

    plot_baseline(
        results, out / "curves.png", f"{args.algorithm.upper()} ({priors.label()}), map {args.map}"
    )
    print(md)
    print(
        f"wrote {out}/ (seed-*/ run folders, summary.md, summary.json, curves.png); "
        f"wall time {wall} s"
    )
    return 0
