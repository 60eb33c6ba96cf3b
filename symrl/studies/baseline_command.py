"""``symrl baseline ALGO``: a short way to train the recipe ``ALGO`` (``sac`` or ``ppo``) on
several seeds. Its flags are mapped onto the recipe's config keys, one ``symrl train`` run per
seed into ``OUT/seed-S`` (:func:`symrl.studies.learners.run_recipe`, in worker processes or,
stoppable by a signal, one after the other); then the summary table, ``summary.json`` and the
learning curves of the seeds.

    --episodes E    run.trials=E            --residual      baseline.residual=true
    --seeds S       run.seed=S, one run each --regions      baseline.regions=true knowledge=regions
    --map M         env.map=M               --correction X  baseline.correction=X
    --envs N        baseline.envs=N         --resume        symrl train --resume OUT/seed-S
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from symrl.studies.baseline import parse_seeds, summarise
from symrl.studies.priors import Priors

__all__ = ["baseline_command", "baseline_overrides", "summary_markdown"]


def baseline_overrides(args: argparse.Namespace, seed: int) -> list[str]:
    """The ``key=value`` overrides of the recipe ``args.algorithm`` that ``args`` stand for."""
    out = [f"run.seed={seed}", f"run.trials={args.episodes}", f"env.map={args.map}"]
    if args.residual:
        out.append("baseline.residual=true")
    if args.regions:  # the region one-hot: the robot is told the region rules
        out += ["baseline.regions=true", "knowledge=regions"]
    if args.correction is not None:
        out.append(f"baseline.correction={args.correction!r}")
    if args.envs is not None:
        out.append(f"baseline.envs={args.envs}")
    return out


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


def _summary(result: Any) -> dict[str, Any]:
    """A run's entry of ``summary.json`` (the report reads its wall times)."""
    config, t = result.config, result.timings
    rows = result.trials
    at20 = None if t["at20_seconds"] != t["at20_seconds"] else t["at20_seconds"]  # nan: none
    return {
        "algorithm": config.baseline.algorithm,
        "variant": _priors(config).label(),
        "seed": result.seed,
        "map": config.env.map,
        "envs": config.baseline.robots,
        "rows": rows,
        "stopped": bool(t["stopped"]),
        "at20": {
            **summarise(rows, 20),
            "wall_time_s": at20,
            "frames": None if at20 is None else int(t["at20_frames"]),
        },
        "end": {
            **summarise(rows, config.run.trials),
            "wall_time_s": round(t["seconds"], 1),
            "frames": int(t["frames"]),
        },
        "cpu_time_s": round(t["cpu_seconds"], 1),
    }


def _priors(config: Any) -> Priors:
    from symrl.studies.priors import priors_of

    return priors_of(config)


def baseline_command(args: argparse.Namespace, signalled: list[int] | None = None) -> int:
    """``symrl baseline ALGO``: one ``symrl train`` run per seed (``OUT/seed-S``), a summary
    table. ``signalled`` (one worker): the signals received; the first stops the run between
    two steps with its state saved (``--resume`` goes on)."""
    from symrl.learner.config import load_config
    from symrl.world.worldmap import load_map

    seeds = parse_seeds(args.seeds)
    configs = [load_config(args.algorithm, baseline_overrides(args, s)) for s in seeds]
    world = load_map(configs[0].env.map)
    label = _priors(configs[0]).label()
    out = Path(args.out or f"results/baseline-{args.algorithm}-{label}")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r}: exists and is not a folder")
    runs = [out / f"seed-{s}" for s in seeds]
    states: list[Any] = []
    for run, config in zip(runs, configs, strict=True):
        states.append(_resumed(run, config) if args.resume else None)
        if states[-1] is None and (run / "config.yaml").exists() and not args.overwrite:
            hint = (
                "it has no checkpoint.pt to go on from"
                if args.resume
                else "pass --overwrite to replace it, or --resume to go on with it"
            )
            raise FileExistsError(f"--out {str(out)!r}: {run.name} already holds a run ({hint})")
    from symrl.locks import holding

    with holding(out, "--out"):
        return _baseline_runs(args, signalled, configs, world, out, runs, states)


def _resumed(run: Path, config: Any) -> dict[str, Any] | None:
    """The run state of the run in ``run`` to go on to ``config``'s budget (None: no run to go
    on with); the run's settings must be the command's (the budget aside)."""
    from symrl.learner.config import config_to_dict
    from symrl.learner.config.baselines import used_settings
    from symrl.runs import CheckpointError
    from symrl.runs.tables import flat
    from symrl.studies.learners import load_run

    if not (run / "checkpoint.pt").is_file():
        return None
    saved, _, state, _ = load_run(run)
    have = flat(used_settings(saved, config_to_dict(saved)))
    want = flat(used_settings(config, config_to_dict(config)))
    for key in sorted(set(have) | set(want)):
        if key != "run.trials" and have.get(key) != want.get(key):
            raise CheckpointError(
                f"--resume {str(run)!r}: the run has {key} {have.get(key)!r}, this command "
                f"{want.get(key)!r}"
            )
    done = len(state["trials"])
    if config.run.trials < done:
        raise ValueError(
            f"--episodes {config.run.trials}: the run in {str(run)!r} has done {done} trials "
            "already"
        )
    return state


def _baseline_runs(
    args: argparse.Namespace,
    signalled: list[int] | None,
    configs: list[Any],
    world: Any,
    out: Path,
    runs: list[Path],
    states: list[Any],
) -> int:
    """The runs of ``symrl baseline`` once its inputs are checked (``out`` locked)."""
    from symrl.studies.learners import run_recipe
    from symrl.studies.runner import run_jobs

    t0 = time.perf_counter()
    stop = (lambda: bool(signalled)) if signalled is not None else None
    jobs = [
        {
            "config": config,
            "logdir": str(run),
            "world": world,
            "overwrite": args.overwrite,
            "resume": state,
            "checkpoint_every": args.checkpoint_every,
            **({"stop": stop} if stop else {}),
        }
        for config, run, state in zip(configs, runs, states, strict=True)
    ]
    label = _priors(configs[0]).label()
    if stop is None:
        results = run_jobs(run_recipe, jobs, workers=args.workers, desc=f"{args.algorithm} {label}")
    else:  # one worker: here, seed after seed, until a signal stops the current run
        results = []
        for job in jobs:
            if signalled:
                break
            results.append(run_recipe(**job))
    if signalled:
        import signal

        where = "before its first run"
        if results:
            last = results[-1]
            where = (
                f"after {len(last.trials)} of {args.episodes} trials of seed "
                f"{last.seed} (its state is saved in {out}/seed-{last.seed}/)"
            )
        print(
            f"symrl baseline: stopped by {signal.Signals(signalled[0]).name} {where}; go "
            "on with the same command and --resume",
            file=sys.stderr,
        )
        return 128 + int(signalled[0])
    wall = round(time.perf_counter() - t0, 1)
    entries = [_summary(r) for r in results]
    summary = [{k: v for k, v in e.items() if k != "rows"} for e in entries]
    seeds = [r.seed for r in results]
    before = out / "summary.json"  # runs of other seeds in the same folder are kept
    if before.is_file():
        kept = [
            r for r in json.loads(before.read_text()).get("runs", []) if r.get("seed") not in seeds
        ]
        summary = sorted(kept + summary, key=lambda r: r["seed"])
    (out / "summary.json").write_text(json.dumps({"runs": summary, "wall_time_s": wall}, indent=2))
    md = summary_markdown(entries)
    (out / "summary.md").write_text(md)
    from symrl.figures import plot_baseline

    plot_baseline(
        entries, out / "curves.png", f"{args.algorithm.upper()} ({label}), map {args.map}"
    )
    print(md)
    print(
        f"wrote {out}/ (seed-*/ run folders, summary.md, summary.json, curves.png); "
        f"wall time {wall} s"
    )
    return 0
