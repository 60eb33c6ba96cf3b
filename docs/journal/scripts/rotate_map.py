"""A map turned by a multiple of 90 degrees, regions included (a script, not a test).

    python docs/journal/scripts/rotate_map.py MAP TURNS OUT.yaml

``MAP`` a built-in name or a map file, ``TURNS`` quarter turns counter-clockwise (1-3). Walls,
start, goal and starts turn about the origin; each region line becomes the line of the other
axis and each rule's comparisons follow it, so every point keeps its region. The learner should
do as well on the turned world as on the original (up to the motion noise's draws): a check of
everything that could prefer one direction (the reflex, the regions, the sub-goals), used for
the check worlds of docs/journal/learning.md, "Worlds never seen before".
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import yaml

from symrl.world import load_map


def _turn(p: list[float], turns: int) -> list[float]:
    x, y = float(p[0]), float(p[1])
    for _ in range(turns):
        x, y = -y, x
    return [round(x, 9), round(y, 9)]


def _turn_regions(regions: dict[str, Any], turns: int) -> dict[str, Any]:
    """One quarter turn at a time: x -> y and y -> -x, so ``x > L`` becomes ``y > L`` and
    ``y > L`` becomes ``x < L`` (with L's value negated)."""
    lines, rules = dict(regions["lines"]), [dict(r) for r in regions["rules"]]
    for _ in range(turns):
        lines = {k: ({"y": v["x"]} if "x" in v else {"x": -v["y"]}) for k, v in lines.items()}
        for rule in rules:
            if "when" not in rule:
                continue
            turned = []
            for condition in rule["when"]:
                axis, op, line = condition.split()
                flipped = {"<": ">", ">": "<"}[op]
                turned.append(f"y {op} {line}" if axis == "x" else f"x {flipped} {line}")
            rule["when"] = turned
    return {**regions, "lines": lines, "rules": rules}


def turned_map(name: str, turns: int) -> dict[str, Any]:
    """The map document of ``name`` turned by ``turns`` quarter turns."""
    world = load_map(name)
    doc = yaml.safe_load(Path(world.source).read_text())
    doc["name"] = f"{doc['name']}_rot{90 * turns}"
    doc["boundary"] = [_turn(p, turns) for p in doc["boundary"]]
    doc["obstacles"] = [[_turn(p, turns) for p in o] for o in doc.get("obstacles") or []]
    doc["segments"] = [[_turn(p, turns) for p in s] for s in doc.get("segments") or []]
    for key in ("start", "goal"):
        x, y = _turn([doc[key]["x"], doc[key]["y"]], turns)
        doc[key] = {**doc[key], "x": x, "y": y}
    doc["start"]["heading"] = round(
        float(doc["start"].get("heading", 0.0)) + turns * math.pi / 2, 9
    )
    if doc.get("starts"):
        doc["starts"] = [
            {
                **s,
                **dict(zip("xy", _turn([s["x"], s["y"]], turns), strict=True)),
                "heading": round(float(s.get("heading", 0.0)) + turns * math.pi / 2, 9),
            }
            for s in doc["starts"]
        ]
    if isinstance(doc.get("regions"), dict):
        doc["regions"] = _turn_regions(doc["regions"], turns)
    return doc


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map")
    parser.add_argument("turns", type=int, choices=(1, 2, 3))
    parser.add_argument("out")
    args = parser.parse_args()
    Path(args.out).write_text(yaml.safe_dump(turned_map(args.map, args.turns), sort_keys=False))
    load_map(args.out)  # it loads (and so is a valid map)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
