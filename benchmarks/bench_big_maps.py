"""Cost against the map's size: env steps per CPU second and map preparation against wall corners.

For the paper's world, the issue's pillar halls (a 20 m room with a k x k grid of pillars) and
office floors (30 m x 50 m and larger, rooms along corridors, desks): ``gym.make`` time, raw
Gymnasium env steps per CPU second (a goal-seeking policy with jitter, trial-like paths, resets
at the end of a trial; each world's rounds alternate with rounds on the paper's world, the
ratio is to those), the planner's time and, with ``--regions``, the time to find the regions
from the walls. The floors carry their own regions (found from the walls, they take minutes:
``--regions`` times that apart, 120 s at most); the pillar halls get one region. The planner is
timed up to 90 s (``-``: beyond the time), also on maps over its corner limit
(``MAX_PLAN_CORNERS``: ``symrl plan`` refuses those, the table marks them).
Prints a Markdown table and writes the plot ``big_maps.png`` (``--out``, default
``docs/figures``).

    python benchmarks/bench_big_maps.py [--steps 3000] [--regions] [--out docs/figures]

CPU time of this process (``time.process_time``): other processes on a shared machine slow the
wall clock, not this figure; the ratios to the paper's world are from the same run.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

import symrl  # noqa: F401  (registers the env)
from symrl import ENV_ID
from symrl.knowledge.planner import shortest_path
from symrl.world.autoregions import auto_regions
from symrl.world.worldmap import MAX_PLAN_CORNERS, load_map

sys.path.insert(0, str(Path(__file__).parent))
from buildings import office_floor, pillar_hall  # noqa: E402

ONE_REGION = {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]}


class _Late(Exception):
    pass


def _late(*_: Any) -> None:
    raise _Late


def limited(fn: Any, seconds: int) -> tuple[Any, float | None]:
    """``fn()`` and its CPU seconds, or (None, None) past ``seconds`` of wall time."""
    signal.signal(signal.SIGALRM, _late)
    signal.alarm(seconds)
    t0 = time.process_time()
    try:
        out = fn()
        return out, time.process_time() - t0
    except _Late:
        return None, None
    finally:
        signal.alarm(0)


def steps_per_second(env: Any, n: int) -> float:
    """Env steps per CPU second under a goal-seeking policy with jitter (resets included)."""
    rng = np.random.default_rng(0)
    jitter = rng.uniform(-0.3, 0.3, n)
    obs, _ = env.reset(seed=0)
    t0 = time.process_time()
    for k in range(n):
        obs, _, terminated, truncated, _ = env.step(
            np.array([obs["goal"][1] + jitter[k]], np.float32)
        )
        if terminated or truncated:
            obs, _ = env.reset()
    return n / (time.process_time() - t0)


def worlds() -> list[dict]:
    paper = load_map("hailu2001")
    out = [{"name": "hailu2001", "map": "hailu2001", "corners": len(paper.segments)}]
    for k in (8, 16):
        hall = pillar_hall(k) | {"regions": ONE_REGION}
        out.append({"name": f"pillar hall {k}x{k}", "doc": hall})
    for w, h, clutter in ((30, 50, 2), (30, 50, 12), (60, 100, 12), (60, 100, 30), (90, 150, 30)):
        out.append(
            {
                "name": f"office {w}x{h} m, {clutter} desks/room",
                "doc": office_floor(w, h, clutter, start=(4.0, 12.0), goal=(0.87 * w, 38.5)),
            }
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--regions", action="store_true", help="also time regions: auto")
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    args = parser.parse_args()
    rows = []
    base = None
    for entry in worlds():
        doc = entry.get("doc")
        # gym.make from the map document: loading and every check of the map included
        source = entry["map"] if doc is None else doc  # the floor's own regions
        env, make_s = limited(lambda s=source: gymnasium.make(ENV_ID, map=s), 120)
        corners = len(env.unwrapped.world.segments)
        # best of --repeats rounds, each world's round next to one of the paper's world, whose
        # best beside it is the ratio's base (the machine is shared: the load drifts)
        if base is None:
            base = env.unwrapped
        pairs = [
            (steps_per_second(env.unwrapped, args.steps), steps_per_second(base, args.steps))
            for _ in range(args.repeats)
        ]
        sps, paper_sps = max(p[0] for p in pairs), max(p[1] for p in pairs)
        world = env.unwrapped.world
        # timed beyond the corner limit too (`symrl plan` refuses those maps: marked in the table)
        plan, plan_s = limited(lambda w=world: shortest_path(w), 90)
        row = {
            "world": entry["name"],
            "corners": corners,
            "make_s": make_s,
            "sps": sps,
            "ratio": sps / paper_sps,
            "paper_sps": paper_sps,
            "plan_s": plan_s,
            "actions": plan.actions if plan else None,
        }
        if args.regions:
            w = world
            _, row["regions_s"] = limited(
                lambda w=w: auto_regions(w.boundary, w.obstacles, w.extra_segments), 120
            )
        sizes = getattr(env.unwrapped._batch.walls, "cell_sizes", list)()
        row["cell_walls"] = float(np.mean(sizes)) if sizes else corners
        rows.append(row)
        print(row, flush=True)
    table = _table(rows, args.regions)
    print(table)
    args.out.mkdir(parents=True, exist_ok=True)
    _plot(rows, args.out / "big_maps.png")


def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _table(rows: list[dict], regions: bool) -> str:
    head = (
        "| world | wall corners | walls per cell | `gym.make` (s) | steps / CPU s | x paper's "
        "| plan (s) | optimum |"
    )
    line = "|---|---:|---:|---:|---:|---:|---:|---:|"
    if regions:
        head += " regions: auto (s) |"
        line += "---:|"
    out = [head, line]
    for r in rows:
        over = " (over the limit)" if r["corners"] > MAX_PLAN_CORNERS else ""
        text = (
            f"| {r['world']} | {r['corners']} | {r['cell_walls']:.0f} "
            f"| {_fmt(r['make_s'], '.2f')} | {r['sps']:,.0f} "
            f"| {r['ratio']:.2f} | {_fmt(r['plan_s'], '.2f')}{over} | "
            f"{r['actions'] if r['actions'] is not None else '-'} |"
        )
        if regions:
            text += f" {_fmt(r.get('regions_s'), '.2f')} |"
        out.append(text)
    return "\n".join(out)


def _plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = sorted(rows, key=lambda r: r["corners"])
    corners = [r["corners"] for r in rows]
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    a.semilogx(corners, [r["sps"] for r in rows], "o-")
    a.set_ylim(bottom=0)
    a.semilogx(
        corners,
        [0.7 * r["paper_sps"] for r in rows],
        "--",
        c="gray",
        label="0.7 x the paper's world, measured beside",
    )
    a.set_xlabel("wall corners")
    a.set_ylabel("env steps per CPU second")
    a.legend()
    for key, label in (("make_s", "gym.make"), ("plan_s", "planner"), ("regions_s", "regions")):
        pts = [(r["corners"], r[key]) for r in rows if r.get(key) is not None]
        if pts:
            b.loglog(*zip(*pts, strict=True), "o-", label=label)
    b.axhline(10.0, ls="--", c="gray", label="10 s")
    b.set_xlabel("wall corners")
    b.set_ylabel("CPU seconds")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
