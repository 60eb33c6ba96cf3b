"""Regions found from the walls (``regions: auto``): rooms and doors at door-like narrowings,
deterministic, valid rules, and on the paper's map the hand partition up to the concave strip."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import yaml

from symrl.knowledge.subgoals import build_subgoals, find_passages
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
    [("two_doors", 2, 2), ("office", 4, 3), ("maze", 4, 0), ("l_corridor", 1, 0)],
)
def test_gallery_auto_regions(name, rooms, doors):
    world = load_map(_auto(name))
    names = world.regions.names
    assert sum(n.startswith("room") for n in names) == rooms
    assert sum(n.startswith("door") for n in names) == doors
    # every free point is in exactly one region and every region has free points
    seen = {world.regions.region_of(x, y) for x, y in _grid(world)}
    assert seen == set(names)


def test_auto_regions_give_the_paper_door_as_sub_goals():
    world = load_map(_auto("hailu2001"))
    passages = {(p.line, p.before, p.after) for p in find_passages(world)}
    assert passages == {("x1", "room2", "door1"), ("x2", "door1", "room1")}
    table = build_subgoals(world)
    room = table.region_names.index("room2")
    assert any(
        abs(x - 3.5) < 1e-6 and abs(y + 0.5) < 1e-6
        for x, y in table.points[room][table.valid[room]].tolist()
    )


def test_bad_regions_value_names_auto():
    with pytest.raises(ValueError, match="'regions' must be 'auto' or a mapping"):
        load_map(_auto("hailu2001") | {"regions": "automatic"})
