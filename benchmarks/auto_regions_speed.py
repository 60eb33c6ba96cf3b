"""How long a map with a 3000-point boundary and no regions takes to load (``regions: auto``).

Run from the repository root: ``python benchmarks/auto_regions_speed.py [--base REV]``. It loads
the same map with ``symrl.world.autoregions`` as checked out and as it is at git revision ``REV``
(default ``main``, read with ``git show``), in one process, so the two times are comparable; the
found regions must be equal. Times are wall-clock on whatever else the machine is doing.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import numpy as np

from symrl.world import autoregions, load_map, worldmap


def wobbly(n: int = 3000) -> dict:
    """A round room of radius 10 m whose wall wobbles by 0.5 m, as ``n`` points."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r = 10 + 0.5 * np.sin(7 * t)
    return {
        "name": "wobbly",
        "boundary": np.round(np.stack([r * np.cos(t), r * np.sin(t)], 1), 6).tolist(),
        "start": {"x": 0.0, "y": 0.0},
        "goal": {"x": 3.0, "y": 0.0, "radius": 0.4},
    }


def module_at(rev: str):
    """``symrl.world.autoregions`` as it is at git revision ``rev``."""
    source = subprocess.run(
        ["git", "show", f"{rev}:symrl/world/autoregions.py"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    path = Path(tempfile.mkdtemp()) / "autoregions_base.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("autoregions_base", path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def timed_load(data: dict, finder) -> tuple[float, object]:
    with mock.patch.object(worldmap, "auto_regions", finder):
        tic = time.perf_counter()
        world = load_map(data)
        return time.perf_counter() - tic, world.regions


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main", help="git revision to compare with")
    parser.add_argument("--points", type=int, default=3000)
    args = parser.parse_args()
    data = wobbly(args.points)
    base = module_at(args.base)
    before, old = timed_load(data, base.auto_regions)
    after, new = timed_load(data, autoregions.auto_regions)
    print(f"{args.points}-point boundary, regions: auto, load_map")
    print(f"  {args.base}: {before:.2f} s")
    print(f"  this checkout: {after:.2f} s ({before / after:.1f}x)")
    print(f"  same regions: {old == new}")
    sys.exit(0 if old == new else 1)


if __name__ == "__main__":
    main()
