"""Round trip: every shipped world drawn as a ROS occupancy map at 5 cm and read back.

For each built-in world and each world of the suites: the planner's optimum (actions of 0.20 m)
on the polygons and on the walls traced back from the image, and the wall corners of both.
``--learn NAME ...``: also ``paper_map``'s actions / optimum on both (a study of ``--sets``
sets x ``--trials`` trials, mean of the last five trials' actions over each world's optimum).

    python benchmarks/round_trip.py [--learn hailu2001 office] [--sets 3] [--trials 20]
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from symrl.knowledge.planner import shortest_path
from symrl.world.rasterize import save_occupancy
from symrl.world.worldmap import SUITES, WorldMap, builtin_maps, load_map, suite_maps


def shipped_regions(name: str) -> Any:
    """A shipped world's hand regions as its map file writes them (None: found from the walls)."""
    text = (resources.files("symrl.world") / "maps" / f"{name}.yaml").read_text()
    return yaml.safe_load(text).get("regions")


def round_trip(world: WorldMap, folder: Path, regions: Any = None) -> Path:
    """The world saved at 5 cm and a symrl map naming it (same start and goal, and the same
    hand ``regions``: without them the map's regions would be found from the traced walls, and
    the learners would be compared on other region rules as well as on other walls)."""
    save_occupancy(world, folder / "map.yaml", 0.05)
    doc: dict[str, Any] = {
        "name": f"{world.name.replace('/', '_')}_ros",
        "occupancy": "map.yaml",
        "start": {"x": world.start.x, "y": world.start.y, "heading": world.start.heading},
        "goal": {"x": world.goal.x, "y": world.goal.y, "radius": world.goal.radius},
    }
    if regions is not None:
        doc["regions"] = regions
    path = folder / "world.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def learned_ratio(source: str, optimum: int, sets: int, trials: int, out: Path) -> float:
    """paper_map's mean actions over the last five trials of every set, over the optimum."""
    subprocess.run(
        [
            sys.executable,
            "-m",
            "symrl",
            "study",
            "paper_map",
            "--map",
            source,
            "--sets",
            str(sets),
            "--trials",
            str(trials),
            "--seed",
            "200",
            "--workers",
            "1",
            "--out",
            str(out),
        ],
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    rows = list(csv.DictReader((out / "trials.csv").open()))
    key = next(k for k in ("actions", "steps") if k in rows[0])
    last = [float(r[key]) for r in rows if int(r["trial"]) > trials - 5]
    return sum(last) / len(last) / optimum


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--learn", nargs="*", default=[])
    parser.add_argument("--sets", type=int, default=3)
    parser.add_argument("--trials", type=int, default=20)
    args = parser.parse_args()
    names = builtin_maps() + [n for s in SUITES for n in suite_maps(s)]
    print("| world | corners | corners back | optimum | optimum back | difference |")
    print("|---|---:|---:|---:|---:|---:|")
    worst = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            world = load_map(name)
            folder = Path(tmp) / name.replace("/", "_")
            folder.mkdir()
            back = load_map(round_trip(world, folder, shipped_regions(name)))
            a, b = shortest_path(world).actions, shortest_path(back).actions
            worst = max(worst, abs(a - b))
            print(
                f"| `{name}` | {len(world.segments)} | {len(back.segments)} | {a} | {b} "
                f"| {b - a:+d} |",
                flush=True,
            )
        print(f"\nlargest difference: {worst} action(s) over {len(names)} worlds")
        for name in args.learn:
            world = load_map(name)
            folder = Path(tmp) / f"learn_{name}"
            folder.mkdir()
            path = round_trip(world, folder, shipped_regions(name))
            optimum = shortest_path(world).actions
            back_optimum = shortest_path(load_map(path)).actions
            r0 = learned_ratio(name, optimum, args.sets, args.trials, folder / "polygons")
            r1 = learned_ratio(str(path), back_optimum, args.sets, args.trials, folder / "ros")
            print(
                f"paper_map on `{name}`: actions / optimum {r0:.3f} (polygons), {r1:.3f} "
                f"(occupancy map), difference {r1 - r0:+.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
