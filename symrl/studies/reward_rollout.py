"""Action sequences of one noise-free trial stepped in the env's own physics, many at once
(:class:`~symrl.world.physics.RobotBatch` with ``noise=False``), and replayed in the Gymnasium
env, with its noise off and on: what :mod:`symrl.studies.reward_optimum` searches with."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symrl.world.physics import RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap

TWO_PI = 2.0 * math.pi


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


def headings_to_actions(headings: np.ndarray, start_heading: float) -> np.ndarray:
    """The turns in [-pi, pi] that point the noise-free robot at ``headings`` in turn."""
    previous = np.concatenate(([start_heading], headings[:-1]))
    return np.array(
        [math.remainder(h - p, TWO_PI) for h, p in zip(headings, previous, strict=True)]
    )


def robots_at(
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


def no_rngs(n: int) -> list[Any]:
    return [None] * n  # noise off: the physics draws nothing


def rollout(
    world: WorldMap, robot: RobotConfig, start: Sequence[float], headings: np.ndarray
) -> Totals:
    """Drive one noise-free robot per row of ``headings`` (M, T) from ``start``; the reward
    is summed until the goal is reached (the trial ends there, as in the env)."""
    headings = np.atleast_2d(np.asarray(headings, dtype=np.float64))
    m, t = headings.shape
    x0, y0, h0 = (float(v) for v in start)
    batch = robots_at(world, robot, np.full(m, x0), np.full(m, y0), np.full(m, h0))
    rngs = no_rngs(m)
    total, f1s, f2s = np.zeros(m), np.zeros(m), np.zeros(m)
    collisions, near = np.zeros(m, int), np.zeros(m, int)
    steps = np.full(m, t)
    live = np.ones(m, dtype=bool)
    current = np.full(m, h0)
    for k in range(t):
        alpha = np.array([math.remainder(a, TWO_PI) for a in (headings[:, k] - current).tolist()])
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


def walk_headings(walk: np.ndarray) -> np.ndarray:
    """The absolute headings of a walk of poses (n+1, 2): one per move."""
    d = np.diff(np.asarray(walk, dtype=np.float64), axis=0)
    return np.arctan2(d[:, 1], d[:, 0])
