"""Regions found from the walls (``regions: auto``): rooms and doors at door-like narrowings,
deterministic, valid rules, and on the paper's map the hand partition up to the concave strip."""

from __future__ import annotations

import hashlib
import json
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import yaml
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from symrl.knowledge.route import option_table
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import find_passages
from symrl.world import load_map
from symrl.world.autoregions import auto_regions

MAPS = Path(str(resources.files("symrl.world") / "maps"))


def _auto(name: str, drop: bool = False) -> dict:
    doc = yaml.safe_load((MAPS / f"{name}.yaml").read_text())
    if drop:
        del doc["regions"]
    else:
        doc["regions"] = "auto"
    return doc


def _grid(world, n: int = 60):
    xmin, xmax, ymin, ymax = world.bounds
    xs, ys = np.meshgrid(np.linspace(xmin, xmax, n), np.linspace(ymin, ymax, n))
    free = world.in_free_area(xs.ravel(), ys.ravel())
    return list(zip(xs.ravel()[free].tolist(), ys.ravel()[free].tolist(), strict=True))


def test_paper_map_auto_regions_match_the_hand_ones_but_the_concave_strip():
    hand = load_map("hailu2001")
    auto = load_map(_auto("hailu2001"))
    assert auto.regions.names == ("room1", "room2", "door1")
    assert dict(auto.regions.lines) == {"x1": ("x", 3.5), "x2": ("x", 3.75)}
    expected = {"room": "room2", "concave": "room2", "door": "door1", "corridor": "room1"}
    for x, y in _grid(hand):
        if x in (3.5, 3.75):
            continue  # on a line both partitions fall through to their defaults
        assert auto.regions.region_of(x, y) == expected[hand.regions.region_of(x, y)]


def test_a_map_without_regions_gets_them_found_and_the_same_every_time():
    first = load_map(_auto("office", drop=True))
    again = load_map(_auto("office"))
    assert first.regions == again.regions
    assert sorted(first.regions.names) == sorted(
        ["room1", "room2", "room3", "room4", "door1", "door2", "door3"]
    )
    world = load_map("office")
    assert auto_regions(world.boundary, world.obstacles, world.extra_segments) == auto_regions(
        world.boundary, world.obstacles, world.extra_segments
    )


@pytest.mark.parametrize(
    ("name", "rooms", "doors"),
    [
        ("two_doors", 4, 2),
        ("two_door_room", 3, 2),
        ("office", 4, 3),
        ("maze", 4, 0),
        ("l_corridor", 3, 0),
        ("dead_end", 5, 0),
    ],
)
def test_gallery_auto_regions(name, rooms, doors):
    world = load_map(_auto(name))
    names = world.regions.names
    assert sum(n.startswith("room") for n in names) == rooms
    assert sum(n.startswith("door") for n in names) == doors
    # every free point is in exactly one region and every region has free points
    seen = {world.regions.region_of(x, y) for x, y in _grid(world)}
    assert seen == set(names)


@pytest.mark.parametrize("name", ["l_corridor", "dead_end"])
def test_corner_cuts_give_the_hand_partition(name):
    """The bend of the L and the pocket of the dead end: no door-like narrowing, but concave
    corners; cut there, the found regions are the hand-drawn ones, region for region."""
    hand = load_map(name)
    auto = load_map(_auto(name))
    assert len(auto.regions.names) == len(hand.regions.names)
    lines = {(axis, c) for axis, c in hand.regions.lines.values()}
    assert {(axis, c) for axis, c in auto.regions.lines.values()} == lines
    match: dict[str, str] = {}
    for x, y in _grid(hand):
        if any(c == (x if axis == "x" else y) for axis, c in lines):
            continue  # on a line
        a = auto.regions.region_of(x, y)
        assert match.setdefault(hand.regions.region_of(x, y), a) == a
    assert len(set(match.values())) == len(match) == len(hand.regions.names)


def test_l_corridor_regions_at_known_poses():
    world = load_map(_auto("l_corridor"))
    of = world.regions.region_of
    # the east arm, the corner square where the arms meet, the north arm
    assert len({of(0.8, 0.9), of(7.1, 0.9), of(7.1, 7.0)}) == 3
    assert of(0.8, 0.9) == of(6.1, 1.7)  # the east arm up to the inner corner's x
    assert of(7.1, 0.9) == of(6.3, 0.1) == of(7.9, 1.7)  # the corner square
    assert of(7.1, 7.0) == of(6.3, 1.9)  # the north arm from the inner corner's y


ROOM = np.array([[0, 0], [6, 0], [6, 4], [0, 4]], float)
NO_WALLS = np.zeros((0, 4))


@pytest.mark.parametrize(("end", "regions"), [(1.8, 2), (2.5, 2), (4.9, 2), (5.2, 1)])
def test_a_thin_wall_end_is_cut_along_its_continuation_up_to_sharp_cut(end, regions):
    # a thin wall from the north wall down to y = 8 - end in a 12 m x 8 m room; the gap below it
    # is wider than a door. From the wall's free end (a sharp corner: 360 degrees free), the
    # chord straight down resolves the corner alone (two 180 degree sectors): cut when it is at
    # most 5 m long (the sideways chords are 6 m)
    room = np.array([[0, 0], [12, 0], [12, 8], [0, 8]], float)
    wall = np.array([[6.0, end, 6.0, 8.0]])
    found = auto_regions(room, [], wall)
    assert len(found["names"]) == regions
    assert found["lines"] == ({"x1": {"x": 6.0}} if regions == 2 else {})


@pytest.mark.parametrize(("width", "regions"), [(3.6, 3), (6.0, 1)])
def test_a_shallow_corner_is_cut_only_up_to_max_cut(width, regions):
    # the north wall bends down by 0.4 m at its middle: a concave corner whose free side spans
    # only about 195-205 degrees. Its chords run 1.8 m or 3 m sideways: cut at 1.8 m (max_cut 2 m;
    # the two slivers above the chords are doors), left whole at 3 m, where a sharp corner
    # (above) would be cut
    boundary = np.array([[0, 0], [width, 0], [width, 4], [width / 2, 3.6], [0, 4]], float)
    found = auto_regions(boundary, [], NO_WALLS)
    assert len(found["names"]) == regions


def test_a_pocket_with_wide_passages_is_cut_off_from_them():
    # a pocket of thin walls, 1.6 m wide (too wide for a door) and 2.5 m deep, opening west in an
    # 8 m x 6.3 m hall; the passages round it are 2.2 m (south) and 2.5 m (north) wide. Its
    # corners are sharp, so their chords (1.6 m to 2.5 m) cut it: west, pocket, south, north and
    # east are separate regions (with a 2 m cap the whole hall was one region)
    hall = np.array([[0, 0], [8, 0], [8, 6.3], [0, 6.3]], float)
    pocket = np.array([[3.0, 2.2, 5.5, 2.2], [3.0, 3.8, 5.5, 3.8], [5.5, 2.2, 5.5, 3.8]])
    found = auto_regions(hall, [], pocket)
    world = load_map(
        {
            "boundary": hall.tolist(),
            "segments": pocket.reshape(-1, 2, 2).tolist(),
            "start": {"x": 1.0, "y": 3.0},
            "goal": {"x": 6.8, "y": 2.8, "radius": 0.4},
            "regions": found,
        }
    )
    of = world.regions.region_of
    west, inside, south, north, east = (
        of(1.0, 3.0),
        of(4.2, 3.0),
        of(4.2, 1.0),
        of(4.2, 5.0),
        of(6.8, 2.8),
    )
    assert len({west, inside, south, north, east}) == 5
    assert of(2.9, 0.3) == of(2.9, 6.0) == west  # the mouth's line x = 3 bounds the west room
    assert of(5.6, 0.3) == east  # and the back wall's x = 5.5 the east one, where the back
    # wall's north end, with two equal 2.5 m chords, makes the north-east square a piece of its own
    assert of(5.6, 6.0) == of(7.9, 3.9) not in {west, inside, south, north, east}


def test_a_bend_is_cut_along_its_narrower_arm():
    # an L whose east arm is 1.2 m wide and whose north arm 1.8 m: at the inner corner the chord
    # across the narrow arm suffices; the 1.8 m one is not taken (no corner square)
    boundary = np.array([[0, 0], [8, 0], [8, 8], [6.2, 8], [6.2, 1.2], [0, 1.2]], float)
    found = auto_regions(boundary, [], NO_WALLS)
    assert found["lines"] == {"x1": {"x": 6.2}}
    assert len(found["names"]) == 2


def test_a_pillar_is_cut_to_the_nearer_walls():
    # a 0.5 m pillar 1.75 m from the north and south walls, 2.75 m from the east and west ones:
    # each corner takes its 1.75 m chord; four regions: west of, east of, below, above the pillar
    pillar = np.array([[2.75, 1.75], [3.25, 1.75], [3.25, 2.25], [2.75, 2.25]])
    found = auto_regions(ROOM, [pillar], NO_WALLS)
    assert found == auto_regions(ROOM, [pillar], NO_WALLS)
    world = load_map(
        {
            "boundary": ROOM.tolist(),
            "obstacles": [pillar.tolist()],
            "start": {"x": 0.5, "y": 0.5},
            "goal": {"x": 5.5, "y": 3.5, "radius": 0.3},
            "regions": found,
        }
    )
    of = world.regions.region_of
    assert len({of(1.0, 2.0), of(5.0, 2.0), of(3.0, 0.5), of(3.0, 3.5)}) == 4
    # 4.25 m and 2.25 m from the walls (its corners are sharp: up to 5 m) it is still cut
    room = np.array([[0, 0], [9, 0], [9, 5], [0, 5]], float)
    assert len(auto_regions(room, [pillar + [1.5, 0.5]], NO_WALLS)["names"]) == 4
    # a pillar more than 5 m from every wall is left whole: one region
    far = np.array([[0, 0], [12, 0], [12, 12], [0, 12]], float)
    assert auto_regions(far, [pillar + [3.0, 3.75]], NO_WALLS)["names"] == ["room1"]


def test_auto_regions_give_the_paper_door_as_sub_goals():
    world = load_map(_auto("hailu2001"))
    passages = {(p.line, p.before, p.after) for p in find_passages(world)}
    assert passages == {("x1", "room2", "door1"), ("x2", "door1", "room1")}
    table = option_table(Knowledge.told(world, "map"), "map")
    room = table.region_names.index("room2")
    assert table.labels[room] == ["route", "goal", "x1>door1"]
    assert table.point(room, 2) == pytest.approx((3.9, -0.5))  # 0.4 m past the door's line


def test_bad_regions_value_names_auto():
    with pytest.raises(ValueError, match="'regions' must be 'auto' or a mapping"):
        load_map(_auto("hailu2001") | {"regions": "automatic"})


def _grid_value(rng, lo: float, hi: float) -> float:
    """A coordinate on a 10 cm grid, so widths hit the thresholds (0.52 m, 1.5 m) exactly."""
    return round(float(rng.integers(round(lo * 10), round(hi * 10) + 1)) / 10, 1)


def _random_map(seed: int) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """A room split by thin walls with gaps, an orthogonal union of boxes with pillars, or a
    star-shaped polygon (seed modulo 3): the walls of a map, from the seed."""
    rng = np.random.default_rng(seed)
    kind = seed % 3
    obstacles: list[np.ndarray] = []
    segments: list[list[float]] = []
    if kind == 0:
        w, h = _grid_value(rng, 4, 10), _grid_value(rng, 3, 8)
        boundary = np.array([[0, 0], [w, 0], [w, h], [0, h]], float)
        for _ in range(rng.integers(1, 4)):
            gap = float(rng.choice([0.4, 0.52, 0.8, 1.0, 1.2, 1.5, 1.6, 2.0, 2.5]))
            if rng.random() < 0.5:
                x, at = _grid_value(rng, 1, w - 1), _grid_value(rng, 0, max(0.0, h - gap))
                segments += [[x, 0, x, at], [x, round(at + gap, 1), x, h]]
            else:
                y, at = _grid_value(rng, 1, h - 1), _grid_value(rng, 0, max(0.0, w - gap))
                segments += [[0, y, at, y], [round(at + gap, 1), y, w, y]]
        segments = [s for s in segments if (s[0], s[1]) != (s[2], s[3])]
    elif kind == 1:
        shape = box(0, 0, _grid_value(rng, 2, 5), _grid_value(rng, 1.5, 3))
        for _ in range(rng.integers(1, 4)):
            x0, y0 = _grid_value(rng, 0, 6), _grid_value(rng, 0, 6)
            part = box(
                x0, y0, round(x0 + _grid_value(rng, 1, 4), 1), round(y0 + _grid_value(rng, 1, 4), 1)
            )
            if shape.intersection(part).area > 0.5:
                shape = unary_union([shape, part])
        shape = shape.simplify(0)
        if shape.geom_type != "Polygon" or len(shape.interiors):
            shape = box(0, 0, 6, 4)
        boundary = np.asarray(shape.exterior.coords)[:-1]
        inner = Polygon(boundary).buffer(-0.6)
        for _ in range(rng.integers(0, 3)):
            x0, y0 = _grid_value(rng, 0, 9), _grid_value(rng, 0, 9)
            pillar = box(
                x0,
                y0,
                round(x0 + _grid_value(rng, 0.2, 1.0), 1),
                round(y0 + _grid_value(rng, 0.2, 1.0), 1),
            )
            if inner.contains(pillar) and not any(
                Polygon(o).intersects(pillar.buffer(0.3)) for o in obstacles
            ):
                obstacles.append(np.asarray(pillar.exterior.coords)[:-1])
    else:
        n = int(rng.integers(6, 16))
        t = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = rng.uniform(3.5, 5, n)
        boundary = np.round(np.stack([r * np.cos(t), r * np.sin(t)], 1), 3)
        if not Polygon(boundary).is_valid:
            boundary = np.round(np.stack([4 * np.cos(t), 3 * np.sin(t)], 1), 3)
        if rng.random() < 0.5:
            pillar = box(-0.3, -0.3, 0.3, 0.3)
            if Polygon(boundary).buffer(-0.5).contains(pillar):
                obstacles.append(np.asarray(pillar.exterior.coords)[:-1])
    return boundary, obstacles, np.asarray(segments, float).reshape(-1, 4)


def _digest(regions: dict) -> str:
    return hashlib.sha256(json.dumps(regions, sort_keys=True).encode()).hexdigest()[:16]


def _pinned_cases() -> dict[str, tuple[np.ndarray, list[np.ndarray], np.ndarray]]:
    cases = {}
    for path in sorted(MAPS.glob("*.yaml")):
        world = load_map(path)
        cases[path.stem] = (world.boundary, list(world.obstacles), world.extra_segments)
    for seed in range(150):
        cases[f"random-{seed}"] = _random_map(seed)
    return cases


PINNED = Path(__file__).with_name("auto_regions_pinned.json")


def test_found_regions_are_the_pinned_ones_on_shipped_and_random_maps():
    """The regions found on every shipped map and on 150 random ones, pinned as digests of the
    ``regions`` mapping: a faster search must find exactly the same rules. First pinned from
    the slow implementation (one shapely intersection per candidate line); re-pinned when sharp
    corners got chords up to 5 m (``sharp_cut``): 52 random maps changed (pillars and thin-wall
    ends 2-5 m from the walls now cut), no shipped map."""
    pinned = json.loads(PINNED.read_text())
    cases = _pinned_cases()
    assert sorted(pinned) == sorted(cases)
    kinds = {len(auto_regions(*cases[f"random-{s}"])["names"]) for s in range(0, 150, 7)}
    assert len(kinds) > 2  # the random maps give partitions of several sizes
    wrong = [name for name, walls in cases.items() if _digest(auto_regions(*walls)) != pinned[name]]
    assert wrong == []
