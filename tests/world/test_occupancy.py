"""ROS occupancy maps as worlds: every map_server field, the traced walls, one-line errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from symrl.knowledge.planner import shortest_path
from symrl.world import MapError, load_map
from symrl.world.occupancy import free_cells, read_occupancy, trace_world
from symrl.world.rasterize import occupancy_image, save_occupancy
from symrl.world.worldmap import builtin_maps, parse_map

RES = 0.1


def room_pixels(rows: int = 40, cols: int = 60) -> np.ndarray:
    """A map_saver image: unknown all round, a wall ring, free inside, a 6 x 6 cell pillar."""
    img = np.full((rows, cols), 205, np.uint8)
    img[2:-2, 2:-2] = 0
    img[4:-4, 4:-4] = 254
    img[17:23, 27:33] = 0
    return img


def write_map(
    folder: Path,
    pixels: np.ndarray,
    *,
    suffix: str = ".pgm",
    start: tuple[float, float] = (1.0, 2.0),
    goal: tuple[float, float] = (5.0, 2.0),
    **fields: object,
) -> Path:
    """The image, its map_server YAML and a symrl map naming it; returns the symrl map."""
    image = folder / f"room{suffix}"
    Image.fromarray(pixels).save(image)
    doc = {
        "image": image.name,
        "resolution": RES,
        "origin": [0.0, 0.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    } | fields
    (folder / "room_ros.yaml").write_text(yaml.safe_dump(doc))
    world = {
        "occupancy": "room_ros.yaml",
        "start": {"x": start[0], "y": start[1]},
        "goal": {"x": goal[0], "y": goal[1], "radius": 0.4},
    }
    path = folder / "world.yaml"
    path.write_text(yaml.safe_dump(world))
    return path


def free_area(world) -> Polygon:
    return Polygon(world.boundary, [p.tolist() for p in world.obstacles])


def test_walls_are_traced_from_the_image(tmp_path):
    world = load_map(write_map(tmp_path, room_pixels()))
    # free cells 4..55 x 4..35 (rows from the bottom), the pillar cells 27..32 x 17..22
    assert world.bounds == pytest.approx((0.4, 5.6, 0.4, 3.6), abs=1e-3)
    assert len(world.obstacles) == 1
    assert Polygon(world.obstacles[0]).bounds == pytest.approx((2.7, 1.7, 3.3, 2.3), abs=1e-3)
    assert world.name == "world"
    assert world.regions.names  # found from the walls when left out
    assert shortest_path(world).actions > 0


@pytest.mark.parametrize("suffix", [".pgm", ".png"])
def test_negate_reads_the_inverted_image_the_same(tmp_path, suffix):
    plain = load_map(write_map(tmp_path, room_pixels(), suffix=suffix))
    inverted = load_map(write_map(tmp_path, 255 - room_pixels(), suffix=suffix, negate=1))
    assert free_area(plain).equals(free_area(inverted))


def test_thresholds_decide_a_grey_cell():
    grey = np.array([[150.0]])  # occupancy (255 - 150) / 255 = 0.41
    assert not free_cells(grey, "trinary", False, 0.65, 0.196)[0, 0]
    assert free_cells(grey, "trinary", False, 0.65, 0.5)[0, 0]
    assert not free_cells(grey, "scale", False, 0.65, 0.196)[0, 0]  # scaled, not free


def test_scale_mode_makes_a_transparent_pixel_unknown(tmp_path):
    rgba = np.stack([room_pixels()] * 3 + [np.full((40, 60), 255, np.uint8)], axis=2)
    rgba[10:30, 20:24, 3] = 0  # a transparent band in the room, its colour still free
    trinary = load_map(write_map(tmp_path, rgba, suffix=".png", mode="trinary"))
    scale = load_map(write_map(tmp_path, rgba, suffix=".png", mode="scale"))
    assert free_area(scale).area == pytest.approx(free_area(trinary).area - 80 * RES**2, abs=0.01)
    assert free_area(trinary).contains(box(2.05, 1.05, 2.35, 2.95))
    assert not free_area(scale).intersects(box(2.05, 1.05, 2.35, 2.95))


def test_raw_mode_reads_occupancy_values(tmp_path):
    raw = np.where(room_pixels() == 254, 0, np.where(room_pixels() == 0, 100, 255))
    world = load_map(write_map(tmp_path, raw.astype(np.uint8), mode="raw"))
    plain = load_map(write_map(tmp_path, room_pixels()))
    assert free_area(world).equals(free_area(plain))


def test_origin_and_yaw_place_the_walls(tmp_path):
    yaw = math.pi / 2  # the image's x axis points north
    world = load_map(
        write_map(
            tmp_path, room_pixels(), origin=[10.0, -1.0, yaw], start=(8.0, 0.0), goal=(8.0, 4.0)
        )
    )
    assert world.bounds == pytest.approx((10.0 - 3.6, 10.0 - 0.4, -0.6, 4.6), abs=1e-3)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"start": (0.1, 0.1)}, "field 'start': (0.1, 0.1) lies in a wall or in unknown space"),
        ({"start": (0.3, 2.0)}, "field 'start': (0.3, 2.0) lies in a wall or in unknown space"),
        ({"goal": (3.0, 2.0)}, "field 'goal': (3.0, 2.0) lies in a wall or in unknown space"),
        ({"goal": (50.0, 2.0)}, "field 'goal': (50.0, 2.0) lies outside the occupancy map"),
        ({"mode": "binary"}, "field 'mode' must be one of ['trinary', 'scale', 'raw']"),
        ({"resolution": 0}, "field 'resolution' must be positive"),
        ({"negate": 2}, "field 'negate' must be 0 or 1"),
        ({"origin": [0, 0, "x"]}, "field 'origin' must be [x, y, yaw]"),
        ({"free_thresh": 0.9}, "need 0 <= free_thresh <= occupied_thresh <= 1"),
        ({"image": "nowhere.pgm"}, "field 'image': "),
    ],
)
def test_bad_input_gets_one_line(tmp_path, change, message):
    where = {k: change.pop(k) for k in ("start", "goal") if k in change}
    path = write_map(tmp_path, room_pixels(), **where, **change)
    with pytest.raises(MapError) as err:
        load_map(path)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_a_goal_in_another_room_is_refused(tmp_path):
    img = room_pixels()
    img[:, 40:42] = 0  # a wall from top to bottom: two rooms
    with pytest.raises(MapError, match="is not in the free space connected to the start"):
        load_map(write_map(tmp_path, img))


def test_an_unreadable_image_is_refused(tmp_path):
    path = write_map(tmp_path, room_pixels())
    (tmp_path / "room.pgm").write_bytes(b"P5 garbage")
    with pytest.raises(MapError, match="cannot read"):
        load_map(path)


def test_occupancy_replaces_the_drawn_walls(tmp_path):
    path = write_map(tmp_path, room_pixels())
    doc = yaml.safe_load(path.read_text()) | {"boundary": [[0, 0], [1, 0], [1, 1]]}
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(MapError, match="'occupancy' takes the place of \\['boundary'\\]"):
        load_map(path)


@settings(max_examples=15, deadline=None)
@given(
    w=st.integers(12, 40),
    h=st.integers(12, 30),
    px=st.integers(0, 6),
    py=st.integers(0, 6),
    res=st.sampled_from([0.05, 0.1, 0.2]),
)
def test_traced_walls_lie_within_one_cell_of_the_image(tmp_path_factory, w, h, px, py, res):
    """A room of w x h free cells with a 3 x 3 pillar: the traced free area differs from the
    free cells by at most one cell anywhere (Hausdorff distance)."""
    img = np.full((h + 4, w + 4), 0, np.uint8)
    img[2:-2, 2:-2] = 254
    img[5 + py : 8 + py, 5 + px : 8 + px] = 0
    folder = tmp_path_factory.mktemp("room")
    write_map(folder, img, resolution=res)
    occ = read_occupancy(folder / "room_ros.yaml")
    boundary, holes = trace_world(
        occ, (2.5 * res, 2.5 * res), ((w + 1.5) * res, (h + 1.5) * res), "t"
    )
    traced = Polygon(boundary, [hole.tolist() for hole in holes])
    rows = img.shape[0]
    truth = unary_union(
        [
            box(c * res, (rows - 1 - r) * res, (c + 1) * res, (rows - r) * res)
            for r, c in zip(*np.nonzero(img == 254), strict=True)
        ]
    )
    assert traced.hausdorff_distance(truth) <= res * 1.001
    assert abs(traced.area - truth.area) <= res * traced.length


def test_a_thin_wall_is_drawn_one_cell_thick_and_ends_where_it_ends():
    # a 4 m x 2 m room with a thin wall on the cell border x = 2.0 from the top to y = 1.0
    world = parse_map(
        {
            "name": "thin",
            "boundary": [[0, 0], [4, 0], [4, 2], [0, 2]],
            "segments": [[[2.0, 2.0], [2.0, 1.0]]],
            "start": {"x": 1.0, "y": 0.5, "heading": 0.0},
            "goal": {"x": 3.0, "y": 1.5, "radius": 0.3},
        }
    )
    res = 0.1
    image, (ox, oy) = occupancy_image(world, res)
    rows = image.shape[0]

    def cell(x: float, y: float) -> int:
        return int(image[rows - 1 - math.floor((y - oy) / res), math.floor((x - ox) / res)])

    across = [cell(x, 1.5) for x in np.arange(0.05, 4.0, res)]
    assert across.count(0) == 1  # one cell thick, not the two cells either side of x = 2
    assert [cell(1.95, 1.05), cell(2.05, 1.05)].count(0) == 1  # down to its end...
    assert cell(1.95, 0.95) == 254 and cell(2.05, 0.95) == 254  # ...and no farther


def test_a_rendered_world_reads_back(tmp_path):
    world = load_map("office")
    image, origin = occupancy_image(world, 0.05)
    assert image.dtype == np.uint8 and set(np.unique(image)) == {0, 205, 254}
    save_occupancy(world, tmp_path / "office_ros.yaml")
    occ = read_occupancy(tmp_path / "office_ros.yaml")
    assert occ.free.sum() == (image == 254).sum()
    assert occ.origin[:2] == pytest.approx(origin)


@pytest.mark.parametrize("name", [n for n in builtin_maps() if not n.startswith("ros_")])
def test_round_trip_keeps_the_optimum(tmp_path, name):
    """Every shipped world drawn at 5 cm and read back: the same optimum within one action."""
    world = load_map(name)
    save_occupancy(world, tmp_path / "ros.yaml", 0.05)
    doc = {
        "occupancy": "ros.yaml",
        "start": {"x": world.start.x, "y": world.start.y, "heading": world.start.heading},
        "goal": {"x": world.goal.x, "y": world.goal.y, "radius": world.goal.radius},
    }
    (tmp_path / "world.yaml").write_text(yaml.safe_dump(doc))
    back = load_map(tmp_path / "world.yaml")
    assert abs(shortest_path(back).actions - shortest_path(world).actions) <= 1


def test_the_shipped_ros_world_loads():
    world = load_map("ros_lab")
    assert len(world.obstacles) >= 2  # the desk, the pillar (and the laser's specks)
    assert shortest_path(world).actions > 0
