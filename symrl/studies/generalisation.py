"""`symrl generalise`: what the learned controller does outside the situation it learned in.

The paper (§9.1.2, §11) reports that its final controller works from start poses inside the
explored region only, fails with a new obstacle, and that odometry error corrupts learning. Three
measurements, each beside the reflex alone (``reflex_only``) on the same seeds:

1. **Other start poses**: train the recipe (``sets`` sets x ``trials`` trials, seed + k), then drive
   the final controller greedily from ``STARTS`` (four near the learned route, four far from it).
2. **New obstacle**: the same controllers, from the usual start, in the map plus ``OBSTACLE``
   (a 0.5 m box on the learned route) via ``WorldMap.with_obstacle``. The obstacle is in the
   env's world only: the agent (its regions, sub-goal table, planner and localiser) is built
   from the map it learned in, as the paper's robot was not told of the box.
3. **Noise**: learning itself under more odometry drift (``env.robot.rotation_noise_deg``) and
   more sonar noise (``env.robot.sonar_noise_std``): the ablation summary per level.

``STARTS`` and ``OBSTACLE`` are the paper's world's. On any other map (``map=``, ``--map``) the
start poses are the map's ``starts:`` or four derived in the start's region and its neighbours
plus four in the other regions, and the obstacle is a box on the shortest path about a third of
the way (``symrl.studies.placement``).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from symrl.studies.placement import OTHER_STARTS
from symrl.studies.runner import evaluate_states, resolve_config, run_sets, summarise

__all__ = [
    "STARTS",
    "OBSTACLE",
    "NOISE_LEVELS",
    "starts_for",
    "obstacle_for",
    "transfer",
    "run_generalisation",
    "generalise_command",
]

STARTS: tuple[tuple[float, float, float], ...] = OTHER_STARTS + (
    (-1.1, -2.1, 0.0),  # the concave corner's far end
    (3.1, 2.1, -math.pi / 2),  # behind the upper door post
    (4.6, 2.0, -math.pi / 2),  # in the corridor, above the door
    (5.1, -3.6, math.pi / 2),  # in the corridor, past the goal
)
"""Four start poses near the learned route (``OTHER_STARTS``) and four far from it."""
NEAR = len(OTHER_STARTS)

OBSTACLE = [[1.75, -0.6], [2.25, -0.6], [2.25, -0.1], [1.75, -0.1]]
"""A 0.5 m box centred on the straight route from the start to the door."""

NOISE_LEVELS: tuple[tuple[str, list[str]], ...] = (
    ("default (rot 0.5 deg, sonar 0.01 m)", []),
    ("odometry rot 2 deg", ["env.robot.rotation_noise_deg=2.0"]),
    ("odometry rot 5 deg", ["env.robot.rotation_noise_deg=5.0"]),
    (
        "odometry rot 5 deg + transl 5%",
        ["env.robot.rotation_noise_deg=5.0", "env.robot.translation_noise=0.05"],
    ),
    ("sonar 0.05 m", ["env.robot.sonar_noise_std=0.05"]),
    ("sonar 0.15 m", ["env.robot.sonar_noise_std=0.15"]),
)
"""(label, config overrides) of the noise sweep."""


def starts_for(world) -> list[tuple[tuple[float, float, float], bool]]:
    """(pose, near the learned route) of every other start pose: ``STARTS`` on the paper's
    world; elsewhere the map's ``starts:`` (near: in the start's region or one next to it) or
    four derived near poses and up to four far ones."""
    from symrl.studies.placement import derived_starts, near_start

    if world.name == "hailu2001":
        return [(p, k < NEAR) for k, p in enumerate(STARTS)]
    if world.starts:
        poses = [(p.x, p.y, p.heading) for p in world.starts]
        return [(p, near_start(world, p)) for p in poses]
    return [(p, True) for p in derived_starts(world, 4)] + [
        (p, False) for p in derived_starts(world, 4, near=False)
    ]


def obstacle_for(world) -> list[list[float]]:
    """The new obstacle: ``OBSTACLE`` on the paper's world, else one placed from the map."""
    from symrl.studies.placement import derived_obstacle

    if world.name == "hailu2001":
        return OBSTACLE
    box = derived_obstacle(world)
    if box is None:
        raise ValueError(
            f"map {world.name!r}: no place on the shortest path for a new obstacle "
            "that leaves the goal reachable"
        )
    return box


def transfer(
    recipe: str, sets: int, trials: int, seed: int, workers: int | None = 1, map: str = "hailu2001"
) -> list[dict[str, Any]]:
    """Train ``recipe`` and take the reflex alone (set k: seed + k) in ``map``; drive both from
    its other start poses, from the usual start, and past the new obstacle. One dict per set."""
    from symrl.world import load_map

    world = load_map(map)
    STARTS = [p for p, _ in starts_for(world)]  # noqa: N806 (the map's own STARTS)
    blocked = world.with_obstacle(obstacle_for(world))
    home = world_start(world)
    out: list[dict[str, Any]] = [{"set": k, "seed": seed + k} for k in range(sets)]
    for who, name, n in (("learned", recipe, trials), ("reflex_only", "reflex_only", 1)):
        config = resolve_config(name, [f"run.trials={n}", f"env.map={map}"])
        states = [s.controller for s in run_sets(config, sets, n, seed, workers=workers)]
        pairs = [(k, j) for k in range(sets) for j in range(len(STARTS))]
        starts = evaluate_states(
            config,
            world,
            [states[k] for k, _ in pairs],
            [STARTS[j] for _, j in pairs],
            [seed + k + 1000 * (j + 1) for k, j in pairs],
        )
        seeds = [seed + k + 999 for k in range(sets)]
        homes = evaluate_states(config, world, states, [home] * sets, seeds)
        # the env holds the new obstacle, the agent only the map it learned in
        walls = evaluate_states(config, world, states, [home] * sets, seeds, env_world=blocked)
        for k in range(sets):
            out[k][who] = {
                "starts": starts[k * len(STARTS) : (k + 1) * len(STARTS)],
                "home": homes[k],
                "obstacle": walls[k],
            }
    return out


def world_start(world) -> tuple[float, float, float]:
    """The map's start pose as a tuple."""
    return (world.start.x, world.start.y, world.start.heading)


def _rate(evs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    reached = [e for e in evs if e["reached_goal"]]
    return {
        "reached": len(reached),
        "runs": len(evs),
        "mean_steps_when_reached": (
            float(np.mean([e["steps"] for e in reached])) if reached else None
        ),
        "mean_collisions": float(np.mean([e["collisions"] for e in evs])),
    }


def run_generalisation(
    recipe: str = "paper_map",
    sets: int = 5,
    trials: int = 20,
    seed: int = 100,
    workers: int | None = 1,
    out: Path | str | None = "results/generalise",
    noise_levels: Sequence[tuple[str, list[str]]] = NOISE_LEVELS,
    map: str = "hailu2001",
) -> dict[str, Any]:
    """All three measurements in ``map`` (name or file); writes ``generalise.json``/``.md`` and
    figures into ``out``."""
    if sets < 1 or trials < 1:
        raise ValueError(f"need at least 1 set and 1 trial, got sets={sets}, trials={trials}")
    from symrl.about import provenance
    from symrl.world import load_map

    t0 = time.perf_counter()
    code = provenance()
    world = load_map(map)
    poses = starts_for(world)
    moved = transfer(recipe, sets, trials, seed, workers, map)
    noisy = [
        run_sets(recipe, sets, trials, seed, [*overrides, f"env.map={map}"], (), workers)
        for _, overrides in noise_levels
    ]
    report: dict[str, Any] = {
        "recipe": recipe,
        "sets": sets,
        "trials": trials,
        "seeds": [seed, seed + sets - 1],
        "provenance": code,
        "map": world.name,
        "start": list(world_start(world)),
        "obstacle": obstacle_for(world),
        "starts": [],
        "noise": [],
    }
    for who in ("learned", "reflex_only"):
        report[f"home_{who}"] = _rate([t[who]["home"] for t in moved])
        report[f"obstacle_{who}"] = _rate([t[who]["obstacle"] for t in moved])
    for k, (start, near) in enumerate(poses):
        report["starts"].append(
            {
                "start": list(start),
                "near_learned_route": near,
                "learned": _rate([t["learned"]["starts"][k] for t in moved]),
                "reflex_only": _rate([t["reflex_only"]["starts"][k] for t in moved]),
            }
        )
    for i, (label, overrides) in enumerate(noise_levels):
        rows = [r for s in noisy[i] for r in s.rows]
        report["noise"].append({"level": label, "overrides": overrides, **summarise(rows)})
    report["wall_time_s"] = round(time.perf_counter() - t0, 1)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "generalise.json").write_text(json.dumps(report, indent=2) + "\n")
        (out / "generalise.md").write_text(markdown(report))
        _figures(moved, out, world, report["obstacle"])
    return report


def _frac(r: dict[str, Any]) -> str:
    steps = r["mean_steps_when_reached"]
    return f"{r['reached']}/{r['runs']}" + (f" ({steps:.1f})" if steps is not None else "")


def markdown(report: dict[str, Any]) -> str:
    """The three tables of the generalisation study."""
    x0, y0, h0 = report.get("start", (0.0, 0.0, 0.0))
    box = np.asarray(report.get("obstacle", OBSTACLE), dtype=float)
    (bx0, by0), (bx1, by1) = box.min(axis=0), box.max(axis=0)
    what = (
        f"{bx1 - bx0:.2g} m box at ({(bx0 + bx1) / 2:.2f}, {(by0 + by1) / 2:.2f})"
        if abs((bx1 - bx0) - (by1 - by0)) < 1e-6
        else "polygon"
    )
    code = report.get("provenance", {})
    revision = f"{code.get('revision') or '?'}{'+dirty' if code.get('dirty') else ''}"
    lines = [
        f"Map `{report.get('map', 'hailu2001')}`. "
        f"Recipe `{report['recipe']}`, {report['sets']} sets x {report['trials']} trials, seeds "
        f"{report['seeds'][0]}-{report['seeds'][1]}, code `{revision}`; greedy "
        "runs with noise on. Cells: reached the goal / runs (mean actions when reached).",
        "",
        "| start pose | near the learned route | learned controller | reflex alone |",
        "| --- | --- | ---: | ---: |",
        f"| usual start ({x0:g}, {y0:g}, {math.degrees(h0):.0f} deg) | yes "
        f"| {_frac(report['home_learned'])} "
        f"| {_frac(report['home_reflex_only'])} |",
    ]
    for s in report["starts"]:
        x, y, h = s["start"]
        lines.append(
            f"| ({x:g}, {y:g}, {math.degrees(h):.0f} deg) "
            f"| {'yes' if s['near_learned_route'] else 'no'} "
            f"| {_frac(s['learned'])} | {_frac(s['reflex_only'])} |"
        )
    lo, ro = report["obstacle_learned"], report["obstacle_reflex_only"]
    lines += [
        "",
        f"| new obstacle ({what}), not on the agent's map | reached | mean collisions |",
        "| --- | ---: | ---: |",
        f"| learned controller | {_frac(lo)} | {lo['mean_collisions']:.1f} |",
        f"| reflex alone | {_frac(ro)} | {ro['mean_collisions']:.1f} |",
        "",
        "| learning under noise | first success (never) | success last 5 | steps last 5 "
        "| total reinf. last 5 | collisions all trials |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for n in report["noise"]:
        fs = n["first_success"]
        mean = f"{fs['mean']:.1f}" if np.isfinite(fs["mean"]) else "-"
        first = f"{mean} ({fs['never']})"
        st, tr, co = n["steps_last5"], n["total_reinforcement_last5"], n["collisions_all_trials"]
        lines.append(
            f"| {n['level']} | {first} | {n['success_last5']:.0%} "
            f"| {st['mean']:.1f} ± {st['std']:.1f} | {tr['mean']:.2f} ± {tr['std']:.2f} "
            f"| {co['mean']:.1f} ± {co['std']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def _figures(transfer: list[dict[str, Any]], out: Path, world, obstacle) -> None:
    from symrl.figures import plot_paths

    t0 = transfer[0]
    plot_paths(
        world,
        [
            ("learned (set 0), other starts", [e["path"] for e in t0["learned"]["starts"]], []),
            ("reflex alone, other starts", [e["path"] for e in t0["reflex_only"]["starts"]], []),
        ],
        out / "starts.png",
        columns=2,
    )
    blocked = world.with_obstacle(obstacle)
    plot_paths(
        blocked,
        [
            (f"learned (set {t['set']}) + new obstacle", [t["learned"]["obstacle"]["path"]], [])
            for t in transfer[:2]
        ]
        + [("reflex alone + new obstacle", [t0["reflex_only"]["obstacle"]["path"]], [])],
        out / "obstacle.png",
        columns=3,
    )


def generalise_command(args: argparse.Namespace) -> int:
    """`symrl generalise`: run, print the tables and the wall time."""
    report = run_generalisation(
        args.recipe, args.sets, args.trials, args.seed, args.workers, args.out, map=args.map
    )
    print(markdown(report))
    print(
        f"wrote {args.out}/ (generalise.md, generalise.json, starts.png, obstacle.png); "
        f"wall time {report['wall_time_s']:.1f} s"
    )
    return 0
