"""`symrl plan`: the optimum of a map, the yardstick of every study, checked move by move.

Actions: each action turns in place (free) then moves ``step`` = 0.20 m, so any path needs at
least ``ceil(L / step)`` actions. ``chord_walk`` builds a walk of that many 0.20 m moves whose
end points lie on the path (so their clearance is ``R``) and checks every move with the env's own
swept-disc test; the lower bound repeated with the body radius alone (0.26 m, a sweep may pass
closer than an end pose) says whether the count is also the optimum under the env's rules.
Two whole searches (the optimum and the bound); the walk's path, 2 mm further out, is re-planned
among the optimum's own corners on a map planned lazily (:func:`walk_path`).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from symrl.knowledge.planner import Plan, robot_clearances, shortest_path
from symrl.world import WorldMap, load_map
from symrl.world.geometry import Walls

__all__ = ["chord_walk", "check_walk", "plan_command", "walk_path"]

WALK_MARGIN = 0.002  # metres added to the clearance of the path the 0.20 m walk follows


def chord_walk(points: np.ndarray, step: float, goal: tuple[float, float], goal_radius: float):
    """Poses of a walk of ``step``-long moves whose end points lie on the polyline ``points``.

    Each next pose is the first point further along the polyline at straight distance ``step``
    from the current one; the walk stops once within ``goal_radius`` of ``goal``. Returns (n+1, 2).
    """
    g = np.asarray(goal, dtype=float)
    points = np.asarray(points, dtype=float)
    if len(points) >= 2:  # the last move may overshoot the end: extend the last leg by one step
        d = points[-1] - points[-2]
        points = np.vstack([points, points[-1] + d * (step / max(float(np.hypot(*d)), 1e-12))])
    cur = points[0].astype(float)
    out = [cur]
    i = 0
    while np.hypot(*(cur - g)) > goal_radius + 1e-12:
        while i + 1 < len(points) and np.hypot(*(points[i + 1] - cur)) < step:
            i += 1
        if i + 1 >= len(points):
            raise ValueError("chord walk ran off the end of the path before reaching the goal")
        a, b = points[i], points[i + 1]
        # solve |a + t (b - a) - cur| = step for the largest t in [0, 1]
        d = b - a
        f = a - cur
        qa, qb, qc = d @ d, 2 * f @ d, f @ f - step * step
        t = (-qb + math.sqrt(max(qb * qb - 4 * qa * qc, 0.0))) / (2 * qa)
        cur = a + min(max(t, 0.0), 1.0) * d
        out.append(cur)
        if len(out) > 10_000:
            raise ValueError("chord walk did not reach the goal in 10,000 moves")
    return np.asarray(out)


def check_walk(world: WorldMap, poses: np.ndarray, body: float, clearance: float) -> dict:
    """Every move of the walk against the env's geometry: sweep contact and end-pose clearance."""
    walls = Walls(world.segments)
    sweep_hits = sum(
        walls.swept_disc_contact(a[0], a[1], b[0], b[1], body)
        for a, b in zip(poses[:-1], poses[1:], strict=True)
    )
    end_clear = walls.clearance(poses[1:])
    return {
        "moves": len(poses) - 1,
        "sweep_contacts": int(sweep_hits),
        "min_end_clearance_m": float(end_clear.min()) if len(end_clear) else float("nan"),
        "virtual_collisions": int(np.sum(end_clear < clearance - 1e-7)),
    }


def replay_in_env(world: str | WorldMap, poses: np.ndarray, heading: float) -> dict | None:
    """Drive the noise-free env through the walk's poses (its action budget the walk's length,
    so a building's long walk is driven to its end); None if the env cannot be made. ``world``:
    a map name or file, or the map already loaded (not loaded and checked again)."""
    try:
        import gymnasium

        import symrl  # noqa: F401  (registers the env)

        env = gymnasium.make(symrl.ENV_ID, noise=False, map=world, max_actions=max(len(poses), 200))
    except Exception:  # the replay is a check of the walk, optional: the plan stands without it
        return None
    env.reset(seed=0, options={"pose": (float(poses[0][0]), float(poses[0][1]), heading)})
    h = heading
    collisions, n, reached, total = 0, 0, False, 0.0
    for a, b in zip(poses[:-1], poses[1:], strict=False):
        want = math.atan2(b[1] - a[1], b[0] - a[0])
        turn = math.remainder(want - h, 2 * math.pi)
        _, reward, term, trunc, info = env.step(np.array([turn], dtype=np.float32))
        total += float(reward)
        h = float(env.unwrapped.true_pose[2])  # type: ignore[attr-defined]
        n += 1
        collisions += int(bool(info["collision"]))
        if term or trunc:
            reached = bool(info["reached_goal"])
            break
    env.close()
    return {
        "actions": n,
        "collisions": collisions,
        "reached_goal": reached,
        "total_reinforcement": round(total, 4),
    }


def walk_path(
    world: WorldMap, start: tuple[float, float] | tuple[float, float, float], plan: Plan
) -> Plan:
    """The path the walk follows: 2 mm further out than ``plan``, so float error never reads
    as a virtual collision.

    On a map the whole graph plans, the shortest path at that clearance; on a larger one the
    shortest path bending round the optimum's own corners only (milliseconds instead of a
    second whole search; the whole search when that finds none). The walk proves what it
    proves whichever path it follows: each of its moves is checked with the env's own tests.
    """
    clearance = plan.clearance + WALK_MARGIN
    if plan.corners and plan.method != Plan.method:  # not the whole graph's plan
        try:
            return shortest_path(world, start, clearance=clearance, among=plan.corners)
        except ValueError:
            pass
    return shortest_path(world, start, clearance=clearance)


def plan_command(args: argparse.Namespace, world: WorldMap | None = None) -> int:
    """`symrl plan`: print the optimum, save ``plan.json`` and ``plan.png`` in ``--out``
    (``world``: ``--map`` already loaded)."""
    from symrl.figures import plot_plan

    t0 = time.perf_counter()
    world = load_map(args.map) if world is None else world
    start = args.start or (world.start.x, world.start.y, world.start.heading)
    body, ir_dist, step = robot_clearances()
    plan = shortest_path(world, start)
    bound = shortest_path(world, start, clearance=body)
    margin = walk_path(world, start, plan)
    walk = chord_walk(margin.points, step, (world.goal.x, world.goal.y), world.goal.radius)
    walk_check = check_walk(world, walk, body, plan.clearance)
    replay = replay_in_env(world, walk, float(start[2]))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result = {
        "map": world.name,
        "start": list(map(float, start)),
        "goal": [world.goal.x, world.goal.y, world.goal.radius],
        **plan.to_dict(),
        "lower_bound": {
            "clearance_m": bound.clearance,
            "length_m": bound.length,
            "actions": bound.actions,
            "why": "a move's sweep needs only the body radius; its end pose needs the IR distance",
        },
        "chord_walk": {"path_clearance_m": margin.clearance, **walk_check},
        "env_replay_noise_free": replay,
        "optimum_actions_exact": bool(
            bound.actions == plan.actions == walk_check["moves"]
            and walk_check["sweep_contacts"] == 0
            and walk_check["virtual_collisions"] == 0
        ),
        "optimum_rule": "fewest 0.20 m moves whose sweeps touch no wall and whose end poses keep "
        "the IR distance; lower bound ceil(L_body / step), achieved by the chord walk",
        "wall_time_s": round(time.perf_counter() - t0, 2),
    }
    (out / "plan.json").write_text(json.dumps(result, indent=2) + "\n")
    plot_plan(world, plan, walk, out / "plan.png")
    print(
        f"shortest path: {plan.length:.3f} m = {plan.actions} actions of {step:.2f} m "
        f"(clearance {plan.clearance:.3f} m); lower bound with the body radius only: "
        f"{bound.length:.3f} m = {bound.actions} actions"
    )
    print(
        f"chord walk: {walk_check['moves']} moves, sweep contacts {walk_check['sweep_contacts']}, "
        f"min end clearance {walk_check['min_end_clearance_m']:.4f} m"
        + (f"; env replay (no noise): {replay}" if replay else "; env not available for a replay")
    )
    print(f"wrote {out / 'plan.json'} and {out / 'plan.png'} in {result['wall_time_s']} s")
    if getattr(args, "reward", False):
        from symrl.studies.reward_optimum import reward_command

        reward_command(args, world, start, walk)
    return 0
