"""A world drawn as a ROS occupancy map: the image and the ``map_server`` YAML of a WorldMap.

The reverse of :mod:`symrl.world.occupancy`: a cell is free (254) when its centre lies in the
free area and no thin wall passes through it (a thin wall is one cell thick), occupied (0)
within ``wall`` metres of the free area (the walls a laser scan sees), unknown (205) beyond, as
``map_saver`` writes a SLAM map.
Used to check that a world survives the round trip and to make example maps.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import shapely
import yaml
from PIL import Image

from symrl.world.worldmap import WorldMap

__all__ = ["occupancy_image", "save_occupancy"]

FREE, OCCUPIED, UNKNOWN = 254, 0, 205
"""The grey levels ``map_saver`` writes."""


def occupancy_image(
    world: WorldMap, resolution: float, wall: float = 0.1, margin: float = 0.5
) -> tuple[np.ndarray, tuple[float, float]]:
    """The world as an 8-bit image (row 0 at the top) and the map origin (x, y) of its
    lower-left corner; ``margin`` metres of unknown space around the walls."""
    xmin, xmax, ymin, ymax = world.bounds
    ox = math.floor((xmin - wall - margin) / resolution) * resolution
    oy = math.floor((ymin - wall - margin) / resolution) * resolution
    cols = int(math.ceil((xmax + wall + margin - ox) / resolution))
    rows = int(math.ceil((ymax + wall + margin - oy) / resolution))
    xs = ox + (np.arange(cols) + 0.5) * resolution
    ys = oy + (np.arange(rows)[::-1] + 0.5) * resolution  # row 0 at the top
    gx, gy = np.meshgrid(xs, ys)
    free_area = world.free_polygon
    free = shapely.contains_xy(free_area, gx, gy)
    for segment in world.extra_segments:
        r, c = _cells_crossed(segment, (ox, oy), resolution, rows)
        free[r, c] = False
    near = free_area.buffer(wall + 0.5 * resolution, join_style="mitre")
    shapely.prepare(near)
    image = np.full((rows, cols), UNKNOWN, dtype=np.uint8)
    image[shapely.intersects_xy(near, gx, gy)] = OCCUPIED
    image[free] = FREE
    return image, (float(ox), float(oy))


def _cells_crossed(
    segment: np.ndarray, origin: tuple[float, float], resolution: float, rows: int
) -> tuple[np.ndarray, np.ndarray]:
    """The (row, column) indices of the cells a thin wall passes through, each cell taken as
    half-open ``[x0, x1) x [y0, y1)``: a wall along a cell border is one cell thick, not two,
    and it ends where it ends, not half a cell beyond."""
    a, b, c, d = (float(v) for v in segment)
    n = max(1, math.ceil(4.0 * math.hypot(c - a, d - b) / resolution))
    t = np.linspace(0.0, 1.0, n + 1)
    col = np.floor((a + t * (c - a) - origin[0]) / resolution).astype(np.int64)
    up = np.floor((b + t * (d - b) - origin[1]) / resolution).astype(np.int64)
    return rows - 1 - up, col


def save_occupancy(
    world: WorldMap, yaml_path: str | Path, resolution: float = 0.05, image_suffix: str = ".pgm"
) -> Path:
    """Write the world as a map_server map: ``<name>.pgm`` (or ``.png``) beside ``yaml_path``
    and the YAML (trinary, the usual thresholds). Returns the YAML's path."""
    yaml_path = Path(yaml_path)
    image, (ox, oy) = occupancy_image(world, resolution)
    image_path = yaml_path.with_suffix(image_suffix)
    Image.fromarray(image, mode="L").save(image_path)
    doc = {
        "image": image_path.name,
        "mode": "trinary",
        "resolution": float(resolution),
        "origin": [round(ox, 9), round(oy, 9), 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,  # map_saver's: its unknown grey (205) reads 0.196, not free
    }
    yaml_path.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return yaml_path
