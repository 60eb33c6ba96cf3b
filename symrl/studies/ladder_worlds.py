"""`symrl ablate --ladder --maps A,B,...`: the knowledge ladder on several worlds, side by side.

Each world gets its own ladder ablation (a sub-folder named after the world, as `symrl ablate
--ladder --map WORLD` writes it); this module reads their trials back and puts every rung on
every world into one table (``ladder-worlds.md``, ``ladder-worlds.json``) and one figure
(``ladder-worlds.png``): actions over the last trials divided by the world's optimum. The
optimum is the planner's shortest path, computed here for the table: a yardstick of the study,
never an input of an agent below the map rung.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from symrl.studies.runner import LAST, curves, optimum

__all__ = [
    "FAILED_FROM",
    "ladder_worlds_command",
    "ladder_worlds_markdown",
    "ladder_worlds_rows",
    "parse_maps",
    "run_ladder_worlds",
    "write_ladder_worlds",
]

FAILED_FROM = 5
"""Trials from this one on count as failed if they miss the goal (as in ``changes.md``)."""


def parse_maps(value: str) -> list[str]:
    """The worlds of ``--maps`` (built-in names, ``suite/world`` names or map files), each
    loaded once to check it; a fault is one line naming the flag and the entry."""
    from symrl.world import load_map
    from symrl.world.worldmap import MapError

    names = [part.strip() for part in value.split(",")]
    if not value.strip(", ") or not all(names):
        raise ValueError(
            f"--maps {value!r}: an empty name in the list; name the worlds, "
            "e.g. hailu2001,check/winding"
        )
    seen: dict[str, str] = {}
    for name in names:
        try:
            world = load_map(name)
        except MapError as err:
            raise ValueError(f"--maps {value!r}: {err}") from None
        if world.name in seen:
            raise ValueError(
                f"--maps {value!r}: {seen[world.name]!r} and {name!r} are both "
                f"named {world.name!r} (one results folder per world name)"
            )
        seen[world.name] = name
    return names


def ladder_worlds_rows(
    rows: Mapping[str, Mapping[str, Sequence[dict[str, Any]]]],
    optima: Mapping[str, int],
    last: int = LAST,
) -> list[dict[str, Any]]:
    """One entry per (world, recipe) of ``rows`` (world -> recipe -> trial rows): actions over
    the last ``last`` trials (per set, then mean and sd over sets; a failed trial counts with
    all its actions), the same divided by the world's optimum, total reinforcement, success
    and failed trials (from trial ``FAILED_FROM`` on, and over all trials)."""
    out = []
    for world, recipes in rows.items():
        opt = int(optima[world])
        for recipe, r in recipes.items():
            steps = curves(r, "steps")[:, -last:].mean(axis=1)
            total = curves(r, "total_reinforcement")[:, -last:].mean(axis=1)
            reached = curves(r, "reached_goal")
            sd = float(steps.std(ddof=1)) if len(steps) > 1 else 0.0
            out.append(
                {
                    "world": world,
                    "recipe": recipe,
                    "optimum": opt,
                    "sets": len(steps),
                    "trials": reached.shape[1],
                    "actions_last": float(steps.mean()),
                    "actions_last_sd": sd,
                    "ratio": float(steps.mean()) / opt,
                    "ratio_sd": sd / opt,
                    "total_last": float(total.mean()),
                    "success_last": float(reached[:, -last:].mean()),
                    "failed_from": sum(
                        1 for x in r if int(x["trial"]) >= FAILED_FROM and not _reached(x)
                    ),
                    "trials_from": sum(1 for x in r if int(x["trial"]) >= FAILED_FROM),
                    "failed_all": sum(1 for x in r if not _reached(x)),
                    "trials_all": len(r),
                }
            )
    return out


def _reached(row: dict[str, Any]) -> bool:
    value = row["reached_goal"]
    return value is True or str(value) == "True" or value == 1


def ladder_worlds_markdown(entries: Sequence[dict[str, Any]], last: int = LAST) -> str:
    """The table of :func:`ladder_worlds_rows`, one row per world and rung."""
    from symrl.knowledge.rungs import RUNGS
    from symrl.learner.config import load_config

    lines = [
        f"| world | optimum actions | rung | recipe | actions last {last} "
        f"| actions / optimum | total reinf. last {last} | success last {last} "
        f"| failed trials from {FAILED_FROM} | failed trials, all |",
        "| --- | ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    rungs = {r: load_config(r).knowledge for r in dict.fromkeys(e["recipe"] for e in entries)}
    worlds = list(dict.fromkeys(e["world"] for e in entries))
    for world in worlds:
        mine = [e for e in entries if e["world"] == world]
        for e in sorted(mine, key=lambda e: RUNGS.index(rungs[e["recipe"]])):  # stable
            lines.append(
                f"| `{world}` | {e['optimum']} | {rungs[e['recipe']]} | `{e['recipe']}` "
                f"| {e['actions_last']:.1f} ± {e['actions_last_sd']:.1f} | {e['ratio']:.2f} "
                f"| {e['total_last']:.2f} | {e['success_last']:.0%} "
                f"| {e['failed_from']} of {e['trials_from']} "
                f"| {e['failed_all']} of {e['trials_all']} |"
            )
    return "\n".join(lines) + "\n"


def run_ladder_worlds(
    maps: Sequence[str],
    recipes: Sequence[str],
    sets: int,
    trials: int,
    seed: int,
    workers: int | None,
    out: Path | str,
    figures: bool = True,
) -> list[dict[str, Any]]:
    """The ladder ablation on every world of ``maps`` (``out/<world name>/``, each as `symrl
    ablate --ladder --map WORLD` writes it), then ``ladder-worlds.md``, ``.json`` and ``.png``
    in ``out``."""
    from symrl.runs import read_trials_csv
    from symrl.studies.ablation import ladder_markdown, run_ablation, summary_markdown
    from symrl.world import load_map

    out = Path(out)
    rows: dict[str, dict[str, list[dict[str, Any]]]] = {}
    optima: dict[str, int] = {}
    for name in maps:
        world = load_map(name).name
        folder = out / world
        summary = run_ablation(
            recipes, sets, trials, seed, workers, folder, figures=figures, map=name
        )
        (folder / "ladder.md").write_text(ladder_markdown(summary))
        print(f"## {world}\n\n{summary_markdown(summary)}", flush=True)
        optima[world] = int(optimum(name)["steps"])
        rows[world] = {r: read_trials_csv(folder / r / "trials.csv") for r in recipes}
    entries = ladder_worlds_rows(rows, optima)
    write_ladder_worlds(out, entries, figures)
    return entries


def write_ladder_worlds(out: Path, entries: Sequence[dict[str, Any]], figures: bool = True) -> None:
    """``ladder-worlds.md``, ``ladder-worlds.json`` and (with ``figures``) ``ladder-worlds.png``."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "ladder-worlds.md").write_text(ladder_worlds_markdown(entries))
    (out / "ladder-worlds.json").write_text(json.dumps(list(entries), indent=2) + "\n")
    if figures:
        from symrl.figures import plot_ladder_worlds

        plot_ladder_worlds(entries, out / "ladder-worlds.png")


def ladder_worlds_command(args: Any) -> int:
    """`symrl ablate --ladder --maps A,B`: run, print the table and the wall time."""
    import time

    from symrl.studies.ablation import LADDER

    if args.recipes or getattr(args, "changes_of", None):
        raise ValueError("--ladder runs its own recipes: give it without --recipes or --changes-of")
    entries = run_ladder_worlds(
        parse_maps(args.maps), LADDER, args.sets, args.trials, args.seed, args.workers, args.out
    )
    print(ladder_worlds_markdown(entries))
    wall = time.perf_counter() - getattr(args, "started", time.perf_counter())
    print(
        f"wrote {args.out}/ (ladder-worlds.md, ladder-worlds.json, ladder-worlds.png, one "
        f"folder per world); wall time {wall:.1f} s"
    )
    return 0
