"""Fast study of learner designs: N sets x T trials with a plain Python loop (no TorchRL).

Drives the env and the fuzzy reflex directly, with the option learner of
``symrl.learner.options`` choosing per region where the reflex's goal-following input points.
It exists to compare designs in seconds; the reported numbers come from ``symrl train``.

    python benchmarks/learning_study.py --design options --seeds 0-9
    python benchmarks/learning_study.py --design reflex --seeds 0-9
    python benchmarks/learning_study.py --design options --set epsilon=0.5 --set reach=0.3
    python benchmarks/learning_study.py --set beyond=0.4 --set min_clearance=0.45 --set d_a=0.5 \
        --near FL=0.1,0.35 --near FR=0.1,0.35 --shield 0.06   # the paper recipe without RBF experts

Prints the last-5-trial means over sets (total reinforcement, actions, collisions), the first
trial from which every later trial reached the goal, and the per-trial curve.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import fields, replace

import gymnasium
import numpy as np
import torch

import symrl  # noqa: F401  (registers the env)
from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig
from symrl.knowledge.regions import RegionMapper
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.knowledge.subgoals import SubgoalConfig, build_subgoals
from symrl.learner.options import OptionConfig, OptionLearner


def run_set(
    seed: int,
    trials: int,
    design: str,
    option_config: OptionConfig,
    subgoal_config: SubgoalConfig,
    noise: bool = True,
    reflex_config: ReflexConfig | None = None,
    shield: IRShield | None = None,
) -> list[dict]:
    """One set: ``trials`` trials of one learner from scratch; env seeded once with ``seed``."""
    env = gymnasium.make("symrl/Hailu2001-v0", noise=noise).unwrapped
    world = env.world
    mapper = RegionMapper.from_map(world)
    reflex = FuzzyReflex(reflex_config)
    table = build_subgoals(world, subgoal_config)
    goal = (world.goal.x, world.goal.y)
    learner = OptionLearner(
        table, goal, option_config, torch.Generator().manual_seed(10_000 + seed)
    )
    out = []
    obs, _ = env.reset(seed=seed)
    for trial in range(trials):
        if trial:
            obs, _ = env.reset()
        total, steps, collisions = 0.0, 0, 0
        while True:
            x, y, h = (float(v) for v in obs["odometry"])
            if design == "reflex":
                angle = float(obs["goal"][1])
            else:
                region = int(mapper(torch.tensor([x, y], dtype=torch.float64)))
                tx, ty = learner.target(region, x, y)
                angle = math.remainder(math.atan2(ty - y, tx - x) - h, 2 * math.pi)
            action = float(reflex(torch.from_numpy(obs["sonar"]), torch.tensor(angle)))
            if shield is not None:
                action, _ = shield.filter(torch.from_numpy(obs["ir"]), action)
            obs, r, term, trunc, info = env.step(np.array([action], dtype=np.float32))
            learner.record(r, bool(info["collision"]))
            total += r
            steps += 1
            collisions += int(info["collision"])
            if term or trunc:
                break
        diag = learner.end_trial()
        out.append(
            {
                "trial": trial + 1,
                "total": total,
                "steps": steps,
                "collisions": collisions,
                "reached": bool(term),
                **diag,
            }
        )
    return out


def summarise(sets: list[list[dict]], last: int = 5) -> dict[str, float]:
    """Last-``last`` means over sets and the first trial from which all later trials reached."""
    tot = np.array([[t["total"] for t in s] for s in sets])
    steps = np.array([[t["steps"] for t in s] for s in sets])
    col = np.array([[t["collisions"] for t in s] for s in sets])
    reached = np.array([[t["reached"] for t in s] for s in sets])
    all_after = [
        next(i + 1 for i in range(reached.shape[1]) if reached[s, i:].all())
        if reached[s, -1]
        else math.inf
        for s in range(reached.shape[0])
    ]
    set_means = tot[:, -last:].mean(axis=1)
    return {
        "total": float(set_means.mean()),
        "total_sd_sets": float(set_means.std()),
        "steps": float(steps[:, -last:].mean()),
        "collisions": float(col[:, -last:].mean()),
        "reached_from": float(max(all_after)),
        "curve_total": tot.mean(axis=0).round(2).tolist(),
        "curve_steps": steps.mean(axis=0).round(1).tolist(),
    }


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def _apply(config, sets: list[str]):
    names = {f.name: f for f in fields(config)}
    changes = {}
    for item in sets:
        key, value = item.split("=", 1)
        if key not in names:
            continue
        current = getattr(config, key)
        if isinstance(current, bool):
            changes[key] = value.lower() in ("1", "true", "yes")
        elif isinstance(current, tuple):
            changes[key] = tuple(float(v) for v in value.split(","))
        else:
            changes[key] = type(current)(value)
    return replace(config, **changes) if changes else config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", choices=["options", "reflex"], default="options")
    parser.add_argument("--seeds", default="0-9")
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument(
        "--set", action="append", default=[], help="key=value (option/subgoal/reflex)"
    )
    parser.add_argument("--no-noise", action="store_true")
    parser.add_argument(
        "--shield", type=float, default=None, metavar="MARGIN", help="IR shield with this margin"
    )
    parser.add_argument(
        "--near",
        action="append",
        default=[],
        metavar="SECTOR=A,B",
        help="reflex NEAR thresholds of one sector, e.g. FL=0.1,0.35 (repeatable)",
    )
    args = parser.parse_args()
    oc = _apply(OptionConfig(), args.set)
    sc = _apply(SubgoalConfig(), args.set)
    rc = _apply(ReflexConfig(), args.set)
    if args.near:
        near = dict(rc.near)
        for item in args.near:
            sector, _, ab = item.partition("=")
            near[sector] = tuple(float(v) for v in ab.split(","))
        rc = replace(rc, near=near)
    shield = None if args.shield is None else IRShield(ShieldConfig(margin=args.shield))
    t0 = time.time()
    sets = [
        run_set(
            s,
            args.trials,
            args.design,
            oc,
            sc,
            noise=not args.no_noise,
            reflex_config=rc,
            shield=shield,
        )
        for s in _seeds(args.seeds)
    ]
    res = summarise(sets)
    print(
        f"design={args.design} seeds={args.seeds} sets={len(sets)} set={args.set}\n"
        f"last5: total {res['total']:.2f} (sd over sets {res['total_sd_sets']:.2f})  "
        f"actions {res['steps']:.1f}  collisions {res['collisions']:.2f}  "
        f"all reach from trial {res['reached_from']}  [{time.time() - t0:.0f}s]"
    )
    print("curve total:", res["curve_total"])
    print("curve steps:", res["curve_steps"])


if __name__ == "__main__":
    main()
