"""``symrl drive``: the fuzzy reflex alone drives one trial (the ``reflex_only`` baseline).

This is the paper's first trial, "no better than what the reflex would have produced": no
learning, just the prior knowledge of section 6.2 in the loop. It shows what the learner
starts from and is the quickest check that the world and the reflex fit together.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import gymnasium
import numpy as np
import torch

from symrl import ENV_ID
from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.world.worldmap import WorldMap

if TYPE_CHECKING:
    from symrl.world.env import Hailu2001Env

__all__ = ["drive", "drive_command"]


def drive(
    start: Sequence[float] | None = None,
    seed: int = 0,
    noise: bool = True,
    map: str | Path | WorldMap | dict[str, Any] = "hailu2001",
    reflex_config: ReflexConfig | None = None,
    max_actions: int = 200,
    shield: ShieldConfig | None = None,
) -> dict[str, Any]:
    """Run one trial with the reflex as the controller; return its numbers and true path.

    The reflex reads the observation's normalised sonars and the signed goal angle
    ``goal[1]`` (from odometry), exactly what the learner's reflex sees.
    Returns ``steps``, ``collisions``, ``total_reinforcement``, ``reached_goal``,
    ``path_length`` (metres, true path), ``path`` (list of true (x, y)), ``odometry_path``,
    ``actions`` (the crisp angles), ``start`` (x, y, heading), ``seed``, ``noise``,
    ``shielded`` (actions the IR shield replaced; 0 without ``shield``).
    """
    reflex = FuzzyReflex(reflex_config)
    env = gymnasium.make(ENV_ID, map=map, noise=noise, max_actions=max_actions)
    base = cast("Hailu2001Env", env.unwrapped)
    guard = None if shield is None else IRShield(shield, base.robot)
    shielded = 0
    try:
        options = None if start is None else {"pose": tuple(float(v) for v in start)}
        obs, _ = env.reset(seed=seed, options=options)
        start_pose = [float(v) for v in base.true_pose]
        total, collisions, reached = 0.0, 0, False
        actions: list[float] = []
        done = False
        with torch.no_grad():
            while not done:
                sonar = torch.from_numpy(np.asarray(obs["sonar"], dtype=np.float32))
                goal_angle = torch.tensor(float(obs["goal"][1]))
                alpha = float(reflex(sonar, goal_angle))
                if guard is not None:
                    alpha, replaced = guard.filter(torch.from_numpy(obs["ir"]), alpha)
                    shielded += int(replaced)
                obs, reward, terminated, truncated, info = env.step(
                    np.array([alpha], dtype=np.float32)
                )
                actions.append(alpha)
                total += float(reward)
                collisions += int(bool(info["collision"]))
                reached = bool(info["reached_goal"])
                done = terminated or truncated
        path = [(float(x), float(y)) for x, y in base.path]
        odometry_path = [(float(x), float(y)) for x, y in base.odometry_path]
    finally:
        env.close()
    xy = np.asarray(path)
    return {
        "steps": len(actions),
        "collisions": collisions,
        "total_reinforcement": total,
        "reached_goal": reached,
        "path_length": float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()),
        "path": path,
        "odometry_path": odometry_path,
        "actions": actions,
        "start": start_pose,
        "seed": seed,
        "noise": bool(noise),
        "shielded": shielded,
    }


def summary(result: dict[str, Any]) -> str:
    """One line of the trial's numbers, as printed by ``symrl drive``."""
    return (
        f"reached goal: {'yes' if result['reached_goal'] else 'no'}  "
        f"steps: {result['steps']}  collisions: {result['collisions']}  "
        f"total reinforcement: {result['total_reinforcement']:.2f}  "
        f"path length: {result['path_length']:.2f} m"
        + (f"  shield vetoes: {result['shielded']}" if result.get("shielded") else "")
    )


def drive_command(args: argparse.Namespace) -> int:
    """CLI handler: drive one trial, save ``path.png`` and ``trial.json`` in ``--out``, print."""
    from symrl.world.worldmap import load_map

    world = load_map(args.map)
    noise = not args.no_noise
    shield = None if args.shield is None else ShieldConfig(margin=args.shield)
    result = drive(start=args.start, seed=args.seed, noise=noise, map=world, shield=shield)
    out = Path(args.out)
    x, y, h = result["start"]
    title = (
        f"reflex{' + IR shield' if shield else ' alone'}, start ({x:g}, {y:g}, "
        f"{math.degrees(h):.0f} deg), seed {args.seed}, "
        f"noise {'on' if noise else 'off'}\n" + summary(result).replace("  total", "\ntotal")
    )
    from symrl.figures import drive_figure

    png = drive_figure(result, world, out / "path.png", title=title)
    (out / "trial.json").write_text(json.dumps(result, indent=1))
    print(f"start ({x:g}, {y:g}, {math.degrees(h):.0f} deg)  {summary(result)}")
    print(f"saved {png} and {out / 'trial.json'}")
    return 0
