"""Big maps: how long loading and the size check take for round rooms of 1k and 10k wall
corners and for large squares, and what the planner and the sub-goal table would cost
(``--build``: build the paper controller's table and paths for the maps within the limits).

    python benchmarks/big_maps.py [--build]
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from symrl.world.worldmap import MapError, check_plannable, load_map, planning_note


def _regions() -> dict:
    return {
        "names": ["west", "east"],
        "lines": {"l": {"x": 0.0}},
        "rules": [{"region": "west", "when": ["x < l"]}, {"region": "east"}],
    }


def ring(n: int) -> dict:
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return {
        "name": f"ring{n}",
        "boundary": np.round(np.stack([5 * np.cos(t), 5 * np.sin(t)], 1), 6).tolist(),
        "start": {"x": -2.5, "y": 0.0},
        "goal": {"x": 2.5, "y": 0.0, "radius": 0.4},
        "regions": _regions(),
    }


def square(half: float) -> dict:
    return {
        "name": f"square{half:g}",
        "boundary": [[-half, -half], [half, -half], [half, half], [-half, half]],
        "start": {"x": -1.0, "y": 0.0},
        "goal": {"x": 1.0, "y": 0.0, "radius": 0.4},
        "regions": _regions(),
    }


def main() -> None:
    build = "--build" in sys.argv
    for doc in (ring(200), ring(1000), ring(10_000), square(50), square(200), square(10_000)):
        t0 = time.perf_counter()
        world = load_map(doc)
        t1 = time.perf_counter()
        try:
            check_plannable(world)
            verdict = planning_note(world) or "prepared in under a second"
        except MapError as err:
            verdict = f"refused: {err}"
        t2 = time.perf_counter()
        line = f"{doc['name']:>12s}: load {t1 - t0:.3f} s, check {t2 - t1:.4f} s; {verdict}"
        if build and not verdict.startswith("refused"):
            from symrl.assembly import build_policy
            from symrl.learner.config import load_config

            t3 = time.perf_counter()
            build_policy(load_config("paper", []), world, [0])
            line += f"; table and paths built in {time.perf_counter() - t3:.2f} s"
        print(line)


if __name__ == "__main__":
    main()
