"""Building-scale worlds for the benchmarks: office floors and pillar halls, as polygon maps and
as the ROS occupancy maps a robot would have saved of them.

``office_floor(width, height, clutter, seed)``: rooms in three columns along two corridors
joined by a cross corridor, a 1 m door per room, ``clutter`` desks and cabinets per room (4
corners each). ``pillar_hall(k)``: the issue's 20 m room with a k x k grid of small pillars.
``write_ros(world, folder)``: the map drawn at 5 cm (PNG + map_server YAML) and a symrl map
naming it with ``occupancy:``.

    python benchmarks/buildings.py OUT_DIR   # writes the 30 m x 50 m floor as a ROS map
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml
from shapely.geometry import Point, Polygon, box
from shapely.ops import unary_union

from symrl.world.rasterize import save_occupancy
from symrl.world.worldmap import WorldMap, load_map

WALL = 0.15
"""Wall thickness (m) between rooms and corridors."""


def _doc(name: str, free: Polygon, start: tuple[float, float], goal: tuple[float, float]) -> dict:
    ring = lambda r: [[round(x, 6), round(y, 6)] for x, y in list(r.coords)[:-1]]  # noqa: E731
    return {
        "name": name,
        "boundary": ring(free.exterior),
        "obstacles": [ring(h) for h in free.interiors],
        "start": {"x": start[0], "y": start[1], "heading": 0.0},
        "goal": {"x": goal[0], "y": goal[1], "radius": 0.4},
        "regions": "auto",
    }


def office_floor(
    width: float = 30.0,
    height: float = 50.0,
    clutter: int = 2,
    seed: int = 0,
    start: tuple[float, float] = (4.0, 12.0),
    goal: tuple[float, float] = (26.0, 38.5),
) -> dict:
    """An office floor ``width`` x ``height`` m (a polygon map document)."""
    rng = np.random.default_rng(seed)
    c1, c2 = 0.3 * width, 0.7 * width  # west edges of the two 2 m corridors
    cross = 0.5 * height - 1.0  # south edge of the 2 m cross corridor
    parts = [box(c1, 0, c1 + 2, height), box(c2, 0, c2 + 2, height), box(c1, cross, c2, cross + 2)]
    # rooms: x from, x to, the corridor's edge and the room's edge its door joins
    columns = [
        (0.0, c1 - WALL, c1, c1 - WALL),
        (c1 + 2 + WALL, c2 - WALL, c1 + 2, c1 + 2 + WALL),
        (c2 + 2 + WALL, width, c2 + 2, c2 + 2 + WALL),
    ]
    furniture = []
    for x0, x1, corridor_x, room_x in columns:
        y = 0.0
        while y < height - 2.0:
            y1 = min(y + 5.0, height)
            if y < cross + 2 and y1 > cross:  # the cross corridor's band: no room
                y = cross + 2 + WALL
                continue
            room = box(x0, y, x1, y1 - WALL if y1 < height else y1)
            parts.append(room)
            d = rng.uniform(y + 0.6, y1 - WALL - 1.6)
            lo, hi = min(corridor_x, room_x) - 0.01, max(corridor_x, room_x) + 0.01
            parts.append(box(lo, d, hi, d + 1.0))
            for _ in range(clutter):
                w, h = rng.uniform(0.3, 1.2), rng.uniform(0.3, 0.8)
                fx = rng.uniform(x0 + 0.9, x1 - w - 0.9)
                fy = rng.uniform(y + 0.9, y1 - h - 0.9)
                piece = box(fx, fy, fx + w, fy + h)
                clear_of_ends = not piece.buffer(0.8).intersects(Point(start)) and not (
                    piece.buffer(1.2).intersects(Point(goal))
                )
                if clear_of_ends and all(piece.distance(f) > 0.8 for f in furniture):
                    furniture.append(piece)
            y = y1
    free = unary_union(parts).difference(unary_union(furniture))
    free = max(getattr(free, "geoms", [free]), key=lambda g: g.area)
    doc = _doc(f"office{width:g}x{height:g}_c{clutter}", free, start, goal)
    # the floor's own partition (finding it from the walls takes minutes on a floor): the room
    # columns, the two corridors and the cross corridor
    doc["regions"] = {
        "names": [
            "west_rooms",
            "west_hall",
            "middle_rooms",
            "cross_hall",
            "east_hall",
            "east_rooms",
        ],
        "lines": {
            "a": {"x": c1},
            "b": {"x": c1 + 2},
            "c": {"x": c2},
            "d": {"x": c2 + 2},
            "s": {"y": cross},
            "n": {"y": cross + 2},
        },
        "rules": [
            {"region": "west_rooms", "when": ["x < a"]},
            {"region": "west_hall", "when": ["x < b"]},
            {"region": "east_rooms", "when": ["x > d"]},
            {"region": "east_hall", "when": ["x > c"]},
            {"region": "cross_hall", "when": ["y > s", "y < n"]},
            {"region": "middle_rooms"},
        ],
    }
    return doc


def pillar_hall(k: int, size: float = 20.0) -> dict:
    """The issue's measurement: a ``size`` m square room with a k x k grid of 0.2 m pillars."""
    pillars = []
    if k:
        pitch = size / (k + 1)
        for i in range(1, k + 1):
            for j in range(1, k + 1):
                x, y = i * pitch + 0.5 * pitch, j * pitch
                pillars.append(box(x - 0.1, y - 0.1, x + 0.1, y + 0.1))
    free = box(0, 0, size, size).difference(unary_union(pillars))
    return _doc(f"pillars{k}", free, (0.5 * size / (k + 1), 1.0), (size - 1.0, size - 1.0))


def write_ros(
    world: WorldMap, folder: Path, resolution: float = 0.05, regions: dict | None = None
) -> Path:
    """The world as a saved ROS map (PNG + map_server YAML) and a symrl map naming it (with
    ``regions`` if given, else found from the walls)."""
    folder.mkdir(parents=True, exist_ok=True)
    save_occupancy(world, folder / f"{world.name}_map.yaml", resolution, image_suffix=".png")
    doc: dict = {
        "name": f"{world.name}_ros",
        "occupancy": f"{world.name}_map.yaml",
        "start": {"x": world.start.x, "y": world.start.y, "heading": world.start.heading},
        "goal": {"x": world.goal.x, "y": world.goal.y, "radius": world.goal.radius},
    }
    if regions is not None:
        doc["regions"] = regions
    path = folder / f"{world.name}_ros.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "out", nargs="?", default="/tmp/symrl-building", help="folder for the ROS map files"
    )
    parser.add_argument(
        "clutter", nargs="?", type=int, default=1, help="desks and cabinets per room (default 1)"
    )
    args = parser.parse_args()
    if args.clutter < 0:
        parser.error(f"clutter {args.clutter}: must be 0 or more")
    doc = office_floor(clutter=args.clutter)
    print(write_ros(load_map(doc), Path(args.out), regions=doc["regions"]))


if __name__ == "__main__":
    main()
