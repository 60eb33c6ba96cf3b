"""`symrl plan --reward`: the best total reinforcement a trial can reach, found by search.

`symrl plan` counts the fewest actions; the learner is paid by the reward, which also charges
every action for its heading error (f2) and for sonar readings near a wall (f1), so the two
optima differ. This module searches the action sequences of one noise-free trial, stepping the
env's own physics (:class:`~symrl.world.physics.RobotBatch` with ``noise=False``, many
sequences at once) and summing its own reward, as the learner's trial total does.

Why a search over positions works: an action sets the heading anew (any turn in [-pi, pi]),
and the reward of a step depends only on where it ends and the heading it was taken with, so
what is left to earn depends on the position alone. Three stages:

1. a value table on a grid of positions (value iteration over ``dp_headings`` headings): a
   guess of what is left to earn from anywhere, to rank the beam's partial sequences;
2. a beam search over ``headings`` absolute headings per action (and the heading straight at
   the goal), keeping per position cell the best sum so far, ranked by sum + table value;
3. coordinate descent on the beam's best sequence, in continuous angles: each heading nudged
   alone, with a later one turned back, and all at random, the step halved when nothing
   improves.

Sequences handed in (``seeds``: the shortest path's walk) are a floor: the result is never
worse. It is a feasible sequence, replayed in :class:`~symrl.world.env.Hailu2001Env`: a lower
bound on the optimum, exact in what it reports, not a proof that nothing is better.

The stepping of sequences (:mod:`symrl.studies.reward_rollout`) and the value table
(:mod:`symrl.studies.reward_value`) have modules of their own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from symrl.studies.reward_rollout import (
    TWO_PI,
    Totals,
    headings_to_actions,
    no_rngs,
    open_loop_with_noise,
    replay,
    robots_at,
    rollout,
    walk_headings,
)
from symrl.studies.reward_value import ValueTable
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap

__all__ = [
    "Best",
    "SearchSettings",
    "Totals",
    "headings_to_actions",
    "open_loop_with_noise",
    "replay",
    "reward_command",
    "rollout",
    "search_best_total",
    "walk_headings",
    "write_result",
]


@dataclass(frozen=True)
class SearchSettings:
    """The search's resolution (defaults: about 15 s on the paper's world on one core)."""

    beam: int = 100
    """Partial sequences kept per depth."""
    headings: int = 144
    """Absolute headings tried per action in the beam (144: every 2.5 degrees)."""
    endings: int = 1
    """The best sequences of each beam that are refined (on the paper's world the 2nd and 3rd
    best of a beam of 144 headings refined into the same sequence as the best)."""
    grids: int = 1
    """Beams run, each on the heading grid turned by a further 1/grids of its spacing, and
    each one's best refined: the landscape has many local optima, and another grid may find
    another (on the paper's world 4 grids of 144 headings found no better one than the first)."""
    cell: float = 0.02
    """Metres: partial sequences ending in the same cell of this size keep only the best."""
    dp_spacing: float = 0.1
    """Metres between the value table's grid points."""
    dp_headings: int = 36
    """Headings per grid point in the value table."""
    refine_start_deg: float = 2.0
    """First nudge of the coordinate descent, degrees (halved down to ``refine_stop_deg``)."""
    refine_stop_deg: float = 0.01
    """Smallest nudge, degrees."""
    random: int = 64
    """Random joint nudges of all headings per descent step (besides one heading at a time)."""


@dataclass
class Best:
    """The best sequence found: absolute headings and the actions (turns) that give them."""

    total: float
    headings: np.ndarray
    actions: np.ndarray
    history: list[tuple[str, float]] = field(default_factory=list)
    """(stage, best total after it)."""


# --- stage 2: the beam ----------------------------------------------------------------------


def _beam(
    world: WorldMap,
    robot: RobotConfig,
    start: Sequence[float],
    settings: SearchSettings,
    value: ValueTable,
    max_actions: int,
    offset: float,
    bar: tqdm | None,
) -> list[tuple[float, np.ndarray]]:
    """The ``endings`` best totals the beam finds, with their headings (best first; none if
    nothing reaches the goal); the heading grid turned by ``offset`` of its spacing."""
    best_total = -np.inf  # the worst of the endings kept, once there are enough
    k = settings.headings
    angles = -math.pi + TWO_PI * (np.arange(k) + offset) / k
    x, y, h = (np.array([float(v)]) for v in start)
    g = np.zeros(1)
    history: list[tuple[np.ndarray, np.ndarray]] = []  # per depth: parent index, heading
    seen: dict[tuple[int, int], float] = {}
    found: list[tuple[float, int, int, float]] = []  # the best endings: total, depth, parent,
    # last heading
    gx, gy = world.goal.x, world.goal.y
    k += 1  # and the heading straight at the goal (a straight run at it pays no f2)
    for depth in range(max_actions):
        n = len(x)
        batch = robots_at(world, robot, np.repeat(x, k), np.repeat(y, k), np.repeat(h, k))
        aim = np.arctan2(gy - y, gx - x)
        want = np.column_stack([np.tile(angles, (n, 1)), aim]).ravel()
        alpha = np.array([math.remainder(a, TWO_PI) for a in (want - np.repeat(h, k)).tolist()])
        r = batch.step(alpha, no_rngs(n * k))
        parent = np.repeat(np.arange(n), k)
        gain = np.repeat(g, k) + r.reward
        keep = ~r.collision
        ended = np.flatnonzero(keep & r.reached_goal)
        for i in ended[np.argsort(-gain[ended], kind="stable")][: settings.endings].tolist():
            found.append((float(gain[i]), depth, int(parent[i]), float(r.true_pose[i, 2])))
        found = sorted(found, key=lambda f: -f[0])[: settings.endings]
        if len(found) == settings.endings:
            best_total = found[-1][0]
        keep &= ~r.reached_goal & (gain > best_total)  # rewards are <= 0: no better later
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"beam depth {depth + 1}: best {best_total:.3f}")
        if not keep.any():
            break
        rows = np.flatnonzero(keep)
        nx, ny = r.true_pose[rows, 0], r.true_pose[rows, 1]
        score = gain[rows] + value(nx, ny)
        cells = np.floor(np.column_stack([nx, ny]) / settings.cell).astype(np.int64)
        order = np.argsort(-gain[rows], kind="stable")  # per cell, the best sum first
        chosen = []
        taken: set[tuple[int, int]] = set()
        for o in order.tolist():
            key = (int(cells[o, 0]), int(cells[o, 1]))
            if key in taken or seen.get(key, -np.inf) >= gain[rows[o]]:
                continue
            taken.add(key)
            seen[key] = float(gain[rows[o]])
            chosen.append(o)
        if not chosen:
            break
        picked = np.array(chosen)
        picked = picked[np.argsort(-score[picked], kind="stable")[: settings.beam]]
        sel = rows[picked]
        history.append((parent[sel], r.true_pose[sel, 2]))
        x, y, h = r.true_pose[sel, 0], r.true_pose[sel, 1], r.true_pose[sel, 2]
        g = gain[sel]
    out = []
    for total, depth, i, last in found:
        headings = [last]
        for d in range(depth - 1, -1, -1):
            parents, heads = history[d]
            headings.append(float(heads[i]))
            i = int(parents[i])
        out.append((total, np.array(headings[::-1])))
    return out


# --- stage 3: coordinate descent --------------------------------------------------------------


def _nudges(t: int) -> np.ndarray:
    """(M, t) directions: each heading alone, and each heading with the one ``lag`` later
    turned the other way (the path between bends sideways, the rest keeps its direction)."""
    eye = np.eye(t)
    rows = [eye]
    for lag in (1, 2, 4):
        if lag < t:
            pair = eye[: t - lag].copy()
            pair[np.arange(t - lag), np.arange(lag, t)] = -1.0
            rows.append(pair)
    one = np.vstack(rows)
    return np.vstack([one, -one])


def _refine(
    world: WorldMap,
    robot: RobotConfig,
    start: Sequence[float],
    headings: np.ndarray,
    settings: SearchSettings,
    bar: tqdm | None,
) -> tuple[float, np.ndarray]:
    """Nudge the headings by +-step (:func:`_nudges`), and all of them at once by random steps
    (``random`` sequences, drawn from a fixed seed), in one batch; take the best change; halve
    the step when none improves. A sequence that stops reaching the goal scores -inf."""
    best = headings.copy()
    total = float(rollout(world, robot, start, best[None]).total[0])
    step = math.radians(settings.refine_start_deg)
    stop = math.radians(settings.refine_stop_deg)
    rng = np.random.default_rng(0)
    while step >= stop:
        t = len(best)
        moves = np.vstack([_nudges(t), rng.standard_normal((settings.random, t))])
        trial = best[None] + step * moves
        totals = rollout(world, robot, start, trial)
        # a sequence that reached the goal early keeps only its first steps
        i = int(np.argmax(totals.total))
        if totals.total[i] > total + 1e-12:
            total = float(totals.total[i])
            best = trial[i][: int(totals.steps[i])].copy()
        else:
            step /= 2
        if bar is not None:
            bar.set_postfix_str(f"refine {math.degrees(step):.3f} deg: best {total:.4f}")
    return total, best


def search_best_total(
    world: WorldMap,
    start: Sequence[float] | None = None,
    seeds: Sequence[np.ndarray] = (),
    settings: SearchSettings | None = None,
    robot: RobotConfig | None = None,
    max_actions: int = 200,
    progress: bool = False,
) -> Best:
    """The best total reinforcement of a noise-free trial from ``start`` (default the map's)
    that the search finds, never worse than any of ``seeds`` (sequences of absolute headings,
    e.g. the shortest path's walk, scored as they are)."""
    settings = settings or SearchSettings()
    robot = robot or RobotConfig()
    if start is None:
        start = (world.start.x, world.start.y, world.start.heading)
    history: list[tuple[str, float]] = []
    # counts the beam's depths (their number is not known ahead); the postfix names the stage
    bar = tqdm(desc="reward optimum", unit="depth", disable=not progress, leave=False)
    try:
        best_total, best = -np.inf, None
        for s in seeds:
            s = np.asarray(s, dtype=np.float64)
            got = rollout(world, robot, start, s[None])
            if got.total[0] > best_total:
                best_total, best = float(got.total[0]), s[: int(got.steps[0])]
        history.append(("seeds", best_total))
        value = ValueTable(world, robot, settings.dp_spacing, settings.dp_headings, bar)
        history.append(("value table", float(value(np.array([start[0]]), np.array([start[1]]))[0])))
        for i in range(settings.grids):
            endings = _beam(
                world, robot, start, settings, value, max_actions, i / settings.grids, bar
            )
            for j, (total, found) in enumerate(endings):
                history.append((f"beam {i + 1}, ending {j + 1}", total))
                total, found = _refine(world, robot, start, found, settings, bar)
                history.append(("refined", total))
                if total > best_total:
                    best_total, best = total, found
        if best is None:
            raise ValueError(f"map {world.name!r}: no action sequence found that reaches the goal")
    finally:
        bar.close()
    return Best(best_total, best, headings_to_actions(best, float(start[2])), history)


def write_result(
    out: Path,
    world: WorldMap,
    start: Sequence[float],
    best: Best,
    shortest: dict[str, Any] | None,
    settings: SearchSettings,
    wall: float,
) -> dict[str, Any]:
    """``reward_optimum.json`` and ``reward_optimum.png`` in ``out``; returns the JSON's data."""
    import json

    from symrl.figures import plot_reward_optimum

    robot = RobotConfig()
    run = replay(world, robot, start, best.actions.tolist())
    result: dict[str, Any] = {
        "map": world.name,
        "start": [float(v) for v in start],
        "noise": False,
        "total_reinforcement": run["total"],
        "actions": run["actions"],
        "reached_goal": run["reached_goal"],
        "collisions": run["collisions"],
        "f1_walls": float(np.sum(run["f1"])),
        "f2_heading": float(np.sum(run["f2"])),
        "near_wall_actions": int(sum(f < 0 for f in run["f1"])),
        "turns_rad": [float(a) for a in best.actions],
        "headings_rad": [float(h) for h in best.headings],
        "per_action": {"f1": run["f1"], "f2": run["f2"]},
        "path": run["path"],
        "shortest_path": shortest,
        "noise_on_open_loop": open_loop_with_noise(world, robot, start, best.actions.tolist()),
        "paper_table1_last_trial": {
            "total_reinforcement": -6.24,
            "actions": 27.7,
            "noise": "a real robot",
        },
        "search": {**settings.__dict__, "stages": best.history},
        "rule": "the sum of f1 + f2 over a noise-free trial's actions (the learner's trial "
        "total), found by search: a reachable total, not a proof that none is better",
        "wall_time_s": round(wall, 1),
    }
    (out / "reward_optimum.json").write_text(json.dumps(result, indent=2) + "\n")
    plot_reward_optimum(world, result, out / "reward_optimum.png")
    return result


def reward_command(args: Any, world: WorldMap, start: Sequence[float], walk: np.ndarray) -> None:
    """`symrl plan --reward`: search from the shortest path's walk, print and write the best
    total (``reward_optimum.json``, ``reward_optimum.png`` in ``--out``)."""
    import time

    t0 = time.perf_counter()
    settings = SearchSettings(beam=args.beam, headings=args.headings)
    robot = RobotConfig()
    seed = walk_headings(walk)
    short = replay(world, robot, start, headings_to_actions(seed, float(start[2])).tolist())
    shortest = {
        "actions": short["actions"],
        "total_reinforcement": short["total"],
        "f1_walls": float(np.sum(short["f1"])),
        "f2_heading": float(np.sum(short["f2"])),
        "path": short["path"],
    }
    best = search_best_total(world, start, [seed], settings, robot, progress=True)
    out = Path(args.out)
    result = write_result(out, world, start, best, shortest, settings, time.perf_counter() - t0)
    print(
        f"best total reinforcement found (noise off): {result['total_reinforcement']:.4f} in "
        f"{result['actions']} actions = f1 (walls) {result['f1_walls']:.4f} + f2 (heading) "
        f"{result['f2_heading']:.4f}; {result['near_wall_actions']} actions near a wall, "
        f"{result['collisions']} collisions"
    )
    print(
        f"shortest path replayed: {shortest['total_reinforcement']:.4f} in {shortest['actions']} "
        f"actions (f1 {shortest['f1_walls']:.4f}, f2 {shortest['f2_heading']:.4f})"
    )
    blind = result["noise_on_open_loop"]
    print(
        f"the same actions with noise on, blind (seeds 0-99): {blind['reached_goal']} of 100 "
        f"reach the goal, those earn {blind['total_when_reached']:.4f} (f1 "
        f"{blind['f1_when_reached']:.4f}, f2 {blind['f2_when_reached']:.4f})"
    )
    print(
        f"wrote {out / 'reward_optimum.json'} and {out / 'reward_optimum.png'} in "
        f"{result['wall_time_s']} s"
    )
