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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from symrl.world.physics import RobotBatch
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

_TWO_PI = 2.0 * math.pi
_CHUNK = 20_000  # robots stepped in one batch by the value table


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
class Totals:
    """What a batch of action sequences earns: one entry per sequence."""

    total: np.ndarray
    """Sum of f1 + f2 up to and including the step that reached the goal (-inf if none did)."""
    steps: np.ndarray
    """Actions up to the goal (the sequence's length if it never got there)."""
    f1: np.ndarray
    f2: np.ndarray
    collisions: np.ndarray
    near_wall: np.ndarray
    """Steps with f1 < 0 and no collision (a sonar reading below d_c)."""


@dataclass
class Best:
    """The best sequence found: absolute headings and the actions (turns) that give them."""

    total: float
    headings: np.ndarray
    actions: np.ndarray
    history: list[tuple[str, float]] = field(default_factory=list)
    """(stage, best total after it)."""


def headings_to_actions(headings: np.ndarray, start_heading: float) -> np.ndarray:
    """The turns in [-pi, pi] that point the noise-free robot at ``headings`` in turn."""
    previous = np.concatenate(([start_heading], headings[:-1]))
    return np.array(
        [math.remainder(h - p, _TWO_PI) for h, p in zip(headings, previous, strict=True)]
    )


def _batch(
    world: WorldMap, robot: RobotConfig, x: np.ndarray, y: np.ndarray, h: np.ndarray
) -> RobotBatch:
    """A noise-free batch of robots placed at the poses (x, y, h), odometry on the true pose."""
    batch = RobotBatch(world, robot, len(x), noise=False, max_actions=10**9)
    ex, ey, clear = batch.walls.closest_many(x, y)
    state = batch.state()
    state.update(
        _x=x.copy(),
        _y=y.copy(),
        _h=h.copy(),
        _xo=x.copy(),
        _yo=y.copy(),
        _ho=h.copy(),
        _ex=ex,
        _ey=ey,
        _clear=clear,
    )
    batch.load_state(state)
    return batch


def _no_rngs(n: int) -> list[Any]:
    return [None] * n  # noise off: the physics draws nothing


def rollout(
    world: WorldMap, robot: RobotConfig, start: Sequence[float], headings: np.ndarray
) -> Totals:
    """Drive one noise-free robot per row of ``headings`` (M, T) from ``start``; the reward
    is summed until the goal is reached (the trial ends there, as in the env)."""
    headings = np.atleast_2d(np.asarray(headings, dtype=np.float64))
    m, t = headings.shape
    x0, y0, h0 = (float(v) for v in start)
    batch = _batch(world, robot, np.full(m, x0), np.full(m, y0), np.full(m, h0))
    rngs = _no_rngs(m)
    total, f1s, f2s = np.zeros(m), np.zeros(m), np.zeros(m)
    collisions, near = np.zeros(m, int), np.zeros(m, int)
    steps = np.full(m, t)
    live = np.ones(m, dtype=bool)
    current = np.full(m, h0)
    for k in range(t):
        alpha = np.array([math.remainder(a, _TWO_PI) for a in (headings[:, k] - current).tolist()])
        r = batch.step(alpha, rngs)
        current = r.true_pose[:, 2]
        total += np.where(live, r.reward, 0.0)
        f1s += np.where(live, r.f1, 0.0)
        f2s += np.where(live, r.f2, 0.0)
        collisions += live & r.collision
        near += live & ~r.collision & (r.f1 < 0)
        arrived = live & r.reached_goal
        steps[arrived] = k + 1
        live &= ~r.reached_goal
        if not live.any():
            break
    total[live] = -np.inf
    return Totals(total, steps, f1s, f2s, collisions, near)


def replay(
    world: WorldMap, robot: RobotConfig, start: Sequence[float], actions: Sequence[float]
) -> dict[str, Any]:
    """The actions in the Gymnasium env (noise off): total, per-step f1 and f2, true path."""
    from symrl.world.env import Hailu2001Env

    env = Hailu2001Env(map=world, noise=False, robot=robot, max_actions=max(len(actions), 1))
    env.reset(seed=0, options={"pose": tuple(float(v) for v in start)})
    total, f1, f2, collisions, reached = 0.0, [], [], 0, False
    for a in actions:
        _, reward, terminated, truncated, info = env.step(np.array([a], dtype=np.float64))
        total += reward
        f1.append(float(info["f1"]))
        f2.append(float(info["f2"]))
        collisions += int(info["collision"])
        reached = bool(info["reached_goal"])
        if terminated or truncated:
            break
    path = [[float(x), float(y)] for x, y in env.path]
    env.close()
    return {
        "total": total,
        "actions": len(f1),
        "reached_goal": reached,
        "collisions": collisions,
        "f1": f1,
        "f2": f2,
        "path": path,
    }


def open_loop_with_noise(
    world: WorldMap,
    robot: RobotConfig,
    start: Sequence[float],
    actions: Sequence[float],
    seeds: int = 100,
) -> dict[str, Any]:
    """The same actions with the env's noise on, blind (seeds 0 .. seeds-1): how many trials
    still reach the goal by the last action, and what those earn. f2 is measured on the
    odometry, which moves as commanded, so it barely changes; f1 and the goal see the true
    pose, which drifts."""
    from symrl.world.env import Hailu2001Env

    env = Hailu2001Env(map=world, noise=True, robot=robot, max_actions=max(len(actions), 1))
    got = []
    for seed in range(seeds):
        env.reset(seed=seed, options={"pose": tuple(float(v) for v in start)})
        f1 = f2 = 0.0
        collisions, reached = 0, False
        for a in actions:
            _, _, terminated, truncated, info = env.step(np.array([a], dtype=np.float64))
            f1, f2 = f1 + float(info["f1"]), f2 + float(info["f2"])
            collisions += int(info["collision"])
            if terminated or truncated:
                reached = bool(terminated)
                break
        got.append((reached, f1, f2, collisions))
    env.close()
    ok = np.array([g[1:3] for g in got if g[0]]).reshape(-1, 2)
    f1, f2 = (float(v) for v in (ok.mean(axis=0) if len(ok) else (np.nan, np.nan)))
    return {
        "seeds": [0, seeds - 1],
        "reached_goal": len(ok),
        "total_when_reached": f1 + f2,
        "f1_when_reached": f1,
        "f2_when_reached": f2,
        "collisions": sum(g[3] for g in got),
    }


# --- stage 1: the value table ---------------------------------------------------------------


class _ValueTable:
    """What is left to earn from a position, by value iteration on a grid (a guess: the grid
    and the heading set are coarse; only used to rank the beam)."""

    def __init__(
        self,
        world: WorldMap,
        robot: RobotConfig,
        spacing: float,
        n_headings: int,
        bar: tqdm | None = None,
    ) -> None:
        xmin, xmax, ymin, ymax = world.bounds
        self.x0, self.y0, self.s = xmin, ymin, spacing
        xs = np.arange(xmin, xmax + spacing / 2, spacing)
        ys = np.arange(ymin, ymax + spacing / 2, spacing)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        px, py = gx.ravel(), gy.ravel()
        walls = RobotBatch(world, robot, 1, noise=False).walls
        ok = world.in_free_area(px, py)
        ok[ok] = walls.clearance(np.column_stack([px[ok], py[ok]])) > robot.radius
        idx = np.flatnonzero(ok)
        k = n_headings
        angles = -math.pi + _TWO_PI * np.arange(k) / k
        n = len(idx)
        reward, done = np.empty((n, k)), np.empty((n, k), dtype=bool)
        nx, ny = np.empty(n * k), np.empty(n * k)
        rows = max(1, _CHUNK // k)  # grid points per batch: bounded memory on big maps
        for a in range(0, n, rows):
            b = min(a + rows, n)
            bx, by = np.repeat(px[idx[a:b]], k), np.repeat(py[idx[a:b]], k)
            batch = _batch(world, robot, bx, by, np.zeros(len(bx)))
            r = batch.step(np.tile(angles, b - a), _no_rngs(len(bx)))
            reward[a:b] = np.where(r.collision, -np.inf, r.reward).reshape(b - a, k)
            done[a:b] = r.reached_goal.reshape(b - a, k)
            nx[a * k : b * k], ny[a * k : b * k] = r.true_pose[:, 0], r.true_pose[:, 1]
        self.shape = gx.shape
        value = np.zeros(len(px))
        valid = np.zeros(len(px), dtype=bool)
        valid[idx] = True
        self.valid = valid
        corners, weights = self._corners(nx, ny)
        for _ in range(2000):
            grid = np.where(valid, value, np.nan)
            later = self._interpolate(grid, corners, weights).reshape(n, k)
            new = np.max(reward + np.where(done, 0.0, later), axis=1)
            change = np.nanmax(np.abs(new - value[idx])) if n else 0.0
            value[idx] = np.maximum(new, -1e3)
            if bar is not None:
                bar.set_postfix_str(f"value table: change {change:.2g}")
            if change < 1e-9:
                break
        self.value = self._fill(np.where(valid, value, np.nan))

    def _corners(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nx, ny = self.shape
        fx, fy = (x - self.x0) / self.s, (y - self.y0) / self.s
        i, j = (
            np.clip(np.floor(fx).astype(int), 0, nx - 2),
            np.clip(np.floor(fy).astype(int), 0, ny - 2),
        )
        tx, ty = np.clip(fx - i, 0, 1), np.clip(fy - j, 0, 1)
        corners = np.stack([i * ny + j, (i + 1) * ny + j, i * ny + j + 1, (i + 1) * ny + j + 1])
        weights = np.stack([(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty])
        return corners, weights

    @staticmethod
    def _interpolate(grid: np.ndarray, corners: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Bilinear over the valid corners (their weights renormalised); -1e3 where none is."""
        v = grid[corners]
        w = np.where(np.isnan(v), 0.0, weights)
        total = w.sum(axis=0)
        out = np.full(v.shape[1], -1e3)
        some = total > 1e-12
        out[some] = (np.nan_to_num(v) * w).sum(axis=0)[some] / total[some]
        return out

    def _fill(self, grid: np.ndarray) -> np.ndarray:
        """Grid points off the free area take their best valid neighbour's value (two rings),
        so positions within a cell of a wall still read a value."""
        g = grid.reshape(self.shape)
        for _ in range(2):
            padded = np.pad(g, 1, constant_values=np.nan)
            stack = np.stack(
                [
                    padded[1 + dx : 1 + dx + g.shape[0], 1 + dy : 1 + dy + g.shape[1]]
                    for dx in (-1, 0, 1)
                    for dy in (-1, 0, 1)
                ]
            )
            best = np.where(
                np.all(np.isnan(stack), axis=0),
                np.nan,
                np.nanmax(np.where(np.isnan(stack), -np.inf, stack), axis=0),
            )
            g = np.where(np.isnan(g), best, g)
        return g.ravel()

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        corners, weights = self._corners(x, y)
        return self._interpolate(self.value, corners, weights)


# --- stage 2: the beam ----------------------------------------------------------------------


def _beam(
    world: WorldMap,
    robot: RobotConfig,
    start: Sequence[float],
    settings: SearchSettings,
    value: _ValueTable,
    max_actions: int,
    offset: float,
    bar: tqdm | None,
) -> list[tuple[float, np.ndarray]]:
    """The ``endings`` best totals the beam finds, with their headings (best first; none if
    nothing reaches the goal); the heading grid turned by ``offset`` of its spacing."""
    best_total = -np.inf  # the worst of the endings kept, once there are enough
    k = settings.headings
    angles = -math.pi + _TWO_PI * (np.arange(k) + offset) / k
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
        batch = _batch(world, robot, np.repeat(x, k), np.repeat(y, k), np.repeat(h, k))
        aim = np.arctan2(gy - y, gx - x)
        want = np.column_stack([np.tile(angles, (n, 1)), aim]).ravel()
        alpha = np.array([math.remainder(a, _TWO_PI) for a in (want - np.repeat(h, k)).tolist()])
        r = batch.step(alpha, _no_rngs(n * k))
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
        value = _ValueTable(world, robot, settings.dp_spacing, settings.dp_headings, bar)
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


def walk_headings(walk: np.ndarray) -> np.ndarray:
    """The absolute headings of a walk of poses (n+1, 2): one per move."""
    d = np.diff(np.asarray(walk, dtype=np.float64), axis=0)
    return np.arctan2(d[:, 1], d[:, 0])


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
