"""The passages of a map: where its region lines cross free space between two regions, oriented
toward the goal, for the paper's map and for any other."""

from __future__ import annotations

import pytest

from symrl.knowledge.subgoals import find_passages
from symrl.world.worldmap import load_map


@pytest.fixture(scope="module")
def world():
    return load_map("hailu2001")


def test_passages_of_the_paper_map_are_the_door_and_the_open_floor(world):
    by_line = {p.line: p for p in find_passages(world)}
    assert set(by_line) == {"l1", "l2", "l3"}
    door_in, door_out, floor = by_line["l2"], by_line["l3"], by_line["l1"]
    assert (door_in.before, door_in.after) == ("room", "door")
    assert (door_out.before, door_out.after) == ("door", "corridor")
    assert door_in.lo == pytest.approx(-1.0, abs=0.02) and door_in.hi == pytest.approx(
        0.0, abs=0.02
    )
    assert door_out.width == pytest.approx(1.0, abs=0.03)
    assert floor.width == pytest.approx(5.0, abs=0.03)  # room/concave: open floor
    assert (floor.before, floor.after) == ("concave", "room")


def test_custom_map_with_two_doors():
    """A room split by a thick wall with one wide opening: a passage on each face of the wall,
    each as wide as the opening."""
    data = {
        "name": "two_doors",
        "boundary": [
            [0, 0],
            [4, 0],
            [4, 1],
            [4.2, 1],
            [4.2, 0],
            [8, 0],
            [8, 4],
            [4.2, 4],
            [4.2, 3.8],
            [4, 3.8],
            [4, 4],
            [0, 4],
        ],
        "start": {"x": 1, "y": 2},
        "goal": {"x": 7, "y": 2, "radius": 0.4},
        "regions": {
            "names": ["west", "wall", "east"],
            "lines": {"a": {"x": 4.0}, "b": {"x": 4.2}},
            "rules": [
                {"region": "east", "when": ["x > b"]},
                {"region": "west", "when": ["x < a"]},
                {"region": "wall"},
            ],
        },
    }
    # the dividing wall is open for y in [1, 3.8] (2.8 m)
    world = load_map(data)
    passages = find_passages(world)
    assert {(p.line, p.before, p.after) for p in passages} == {
        ("a", "west", "wall"),
        ("b", "wall", "east"),
    }
    a = next(p for p in passages if p.line == "a")
    assert (a.lo, a.hi) == (pytest.approx(1.0, abs=0.02), pytest.approx(3.8, abs=0.02))


def test_a_door_closed_by_a_thin_wall_is_no_passage():
    doc = {
        "name": "closed",
        "boundary": [[0, 0], [8, 0], [8, 4], [0, 4]],
        # a thin wall at x = 4 with two 1 m doors; the upper one is closed by one more segment
        "segments": [
            [[4.0, 0.0], [4.0, 0.5]],
            [[4.0, 1.5], [4.0, 2.5]],
            [[4.0, 2.5], [4.0, 3.5]],
            [[4.0, 3.5], [4.0, 4.0]],
        ],
        "start": {"x": 1, "y": 2},
        "goal": {"x": 7, "y": 2, "radius": 0.4},
        "regions": {
            "names": ["west", "east"],
            "lines": {"wall": {"x": 4.0}},
            "rules": [{"region": "west", "when": ["x < wall"]}, {"region": "east"}],
        },
    }
    world = load_map(doc)
    passages = find_passages(world)
    assert len(passages) == 1  # only the lower door, y in [0.5, 1.5]
    assert passages[0].lo == pytest.approx(0.5, abs=0.02)
    assert passages[0].hi == pytest.approx(1.5, abs=0.02)
