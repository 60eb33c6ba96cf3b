"""Write the shipped ROS occupancy world ``ros_lab``: a saved map_server map and its symrl map.

Run from the repository root: ``python docs/scripts/ros_example_map.py``. A small lab floor (two
rooms off an L-shaped hall, a desk and a pillar) is drawn as polygons, rendered at 5 cm the way
``map_saver`` writes a SLAM map (free 254, walls 0, unknown 205 around) with a few specks of
laser noise, and saved as ``symrl/world/maps/ros/lab.pgm`` + ``lab.yaml``; the symrl map
``symrl/world/maps/ros_lab.yaml`` names it with ``occupancy:`` and lets the regions be found.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from symrl.world.rasterize import OCCUPIED, save_occupancy
from symrl.world.worldmap import load_map

MAPS = Path("symrl/world/maps")

LAB = {
    "name": "lab_polygons",
    # hall along the south (0..9 x 0..1.6) and up the east side (7.4..9 x 0..7); two rooms
    # north of the hall (0..3.4 and 3.6..7.2, y 1.85..7) with 1 m doors
    "boundary": [
        [0.0, 0.0],
        [9.0, 0.0],
        [9.0, 7.0],
        [7.4, 7.0],
        [7.4, 1.6],
        [6.4, 1.6],
        [6.4, 1.85],
        [7.2, 1.85],
        [7.2, 7.0],
        [3.6, 7.0],
        [3.6, 1.85],
        [5.4, 1.85],
        [5.4, 1.6],
        [2.6, 1.6],
        [2.6, 1.85],
        [3.4, 1.85],
        [3.4, 7.0],
        [0.0, 7.0],
        [0.0, 1.85],
        [1.6, 1.85],
        [1.6, 1.6],
        [0.0, 1.6],
    ],
    "obstacles": [
        [[0.8, 4.0], [2.4, 4.0], [2.4, 4.8], [0.8, 4.8]],  # a desk in the west room
        [[5.1, 4.2], [5.6, 4.2], [5.6, 4.7], [5.1, 4.7]],  # a pillar in the east room
    ],
    "start": {"x": 1.2, "y": 6.0, "heading": 0.0},
    "goal": {"x": 6.2, "y": 6.0, "radius": 0.4},
    "regions": "auto",
}

MAP_FILE = """\
# A saved ROS map as a symrl world: `occupancy:` names the map_server YAML (relative to this
# file); the walls are traced from its image, the regions found from the walls. Written by
# docs/scripts/ros_example_map.py.
name: ros_lab
occupancy: ros/lab.yaml
start: {x: 1.2, y: 6.0, heading: 0.0}
goal: {x: 6.2, y: 6.0, radius: 0.40}
"""


def main() -> None:
    world = load_map(LAB)
    yaml_path = save_occupancy(world, MAPS / "ros" / "lab.yaml", resolution=0.05)
    image_path = yaml_path.with_suffix(".pgm")
    pixels = np.array(Image.open(image_path))
    for row, col in ((60, 30), (90, 150), (110, 170)):  # laser noise: lone occupied cells
        pixels[row, col] = OCCUPIED
    Image.fromarray(pixels, mode="L").save(image_path)
    (MAPS / "ros_lab.yaml").write_text(MAP_FILE)
    print(
        f"wrote {image_path} ({image_path.stat().st_size} bytes), {yaml_path}, "
        f"{MAPS / 'ros_lab.yaml'}"
    )


if __name__ == "__main__":
    main()
