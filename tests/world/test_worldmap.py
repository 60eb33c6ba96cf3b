"""The map loader: the shipped map, user files, and one clear error per kind of fault."""

import copy
import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import yaml

from symrl.world import MapError, load_map
from symrl.world.env import Hailu2001Env
from symrl.world.worldmap import builtin_maps

MAP_FILE = Path(str(resources.files("symrl.world") / "maps" / "hailu2001.yaml"))


@pytest.fixture()
def doc() -> dict:
    return yaml.safe_load(MAP_FILE.read_text())


def test_builtin_map_matches_the_spec():
    world = load_map("hailu2001")
    assert "hailu2001" in builtin_maps()
    assert world.bounds == (-1.5, 5.55, -4.0, 2.5)
    assert (world.start.x, world.start.y, world.start.heading) == (0.0, 0.0, 0.0)
    assert (world.goal.x, world.goal.y, world.goal.radius) == (4.0, -2.0, 0.40)
    assert world.segments.shape == (12, 4)
    # the door (x in [3.5, 3.75], y in [-1, 0]) is free, the dividing wall is not
    assert world.in_free_area(3.6, -0.5) and not world.in_free_area(3.6, 1.0)
    assert world.regions.names == ("room", "concave", "door", "corridor")
    assert world.regions.region_of(0.0, 0.0) == "room"
    assert world.regions.region_of(1.0, -2.0) == "concave"
    assert world.regions.region_of(3.6, -0.5) == "door"
    assert world.regions.region_of(4.5, 0.0) == "corridor"


def test_user_map_file_loads_and_drives(tmp_path, doc):
    # a smaller room with a pillar; start and goal in it
    doc.update(
        name="pillar",
        boundary=[[0, 0], [4, 0], [4, 3], [0, 3]],
        obstacles=[[[1.8, 1.2], [2.2, 1.2], [2.2, 1.8], [1.8, 1.8]]],
        segments=[[[3.0, 0.0], [3.0, 0.8]]],
        start={"x": 0.5, "y": 1.5, "heading": 0.0},
        goal={"x": 3.5, "y": 1.5, "radius": 0.3},
    )
    path = tmp_path / "pillar.yaml"
    path.write_text(yaml.safe_dump(doc))
    world = load_map(path)
    assert world.name == "pillar" and world.segments.shape == (4 + 4 + 1, 4)
    assert not world.in_free_area(2.0, 1.5)
    env = Hailu2001Env(map=str(path), noise=False)
    obs, _ = env.reset(seed=0)
    # ahead: the pillar's face x = 1.8 at 1.3 m from the centre
    assert obs["sonar"][0] * 5.0 == pytest.approx(1.3 - 0.26)
    assert Hailu2001Env(map=world).world is world


def test_with_obstacle_accepts_numpy(doc):
    world = load_map(doc).with_obstacle(np.array([[0.5, 0.5], [1.0, 0.5], [1.0, 1.0]]))
    assert len(world.obstacles) == 1 and not world.in_free_area(0.9, 0.6)


def _mutate(doc: dict, path: str, value) -> dict:
    """Set ``doc[path]`` (dotted, with integer list indices); value ``...`` deletes the key."""
    out = copy.deepcopy(doc)
    *parents, last = path.split(".")
    node = out
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    if isinstance(node, list):
        node[int(last)] = value
    elif value is ...:
        del node[last]
    else:
        node[last] = value
    return out


BAD_MAPS = [
    ("missing field", "goal", ..., "missing required field 'goal'"),
    ("unknown field", "walls", [], "unknown field"),
    ("non-numeric coordinate", "boundary.0", ["a", -2.5], r"boundary\[0\]\[0\].*number"),
    ("NaN coordinate", "boundary.1", [math.nan, -2.5], r"boundary\[1\]\[0\].*finite"),
    ("point with 3 values", "boundary.2", [1.0, 2.0, 3.0], r"boundary\[2\].*point"),
    ("polygon with 2 points", "boundary", [[0, 0], [1, 1]], "at least 3 points"),
    (
        "self-crossing polygon",
        "boundary",
        [[0, 0], [2, 2], [2, 0], [0, 2]],
        "crosses itself",
    ),
    ("zero-area polygon", "boundary", [[0, 0], [1, 1], [2, 2]], "zero area"),
    ("repeated point", "boundary", [[0, 0], [2, 0], [2, 0], [0, 2]], "coincide"),
    ("goal outside free area", "goal", {"x": 3.6, "y": 1.0, "radius": 0.4}, "'goal'.*free area"),
    ("start outside free area", "start", {"x": 9.0, "y": 0.0}, "'start'.*free area"),
    ("negative goal radius", "goal.radius", -0.4, "goal.radius.*positive"),
    ("goal radius not a number", "goal.radius", "big", "goal.radius.*number"),
    ("unknown start key", "start", {"x": 0, "y": 0, "theta": 1}, "unknown key"),
    ("unknown region in rule", "regions.rules.0", {"region": "hall"}, "unknown region 'hall'"),
    (
        "bad condition syntax",
        "regions.rules.0",
        {"region": "corridor", "when": ["x >> l3"]},
        "cannot read condition",
    ),
    (
        "unknown line",
        "regions.rules.0",
        {"region": "corridor", "when": ["x > l9"]},
        "unknown line 'l9'",
    ),
    (
        "axis mismatch",
        "regions.rules.0",
        {"region": "corridor", "when": ["y > l3"]},
        "x-line",
    ),
    ("last rule not default", "regions.rules.3", {"region": "door", "when": ["x > l2"]}, "last"),
    ("bad line spec", "regions.lines.l1", {"z": 1.0}, "regions.lines.l1"),
    ("duplicate region names", "regions.names", ["room", "room"], "duplicates"),
    ("zero-length segment", "segments", [[[0, 0], [0, 0]]], r"segments\[0\].*zero length"),
    ("bad name", "name", "", "'name'"),
    (
        "typo in a rule key",
        "regions.rules.0",
        {"region": "corridor", "whne": ["x > l3"]},
        r"rules\[0\].*unknown key.*whne",
    ),
    ("unknown regions key", "regions.colours", {}, r"'regions'.*unknown key.*colours"),
]


@pytest.mark.parametrize(
    ("fault", "path", "value", "message"), BAD_MAPS, ids=[b[0] for b in BAD_MAPS]
)
def test_malformed_map_is_rejected_naming_the_fault(doc, fault, path, value, message):
    with pytest.raises(MapError, match=message):
        load_map(_mutate(doc, path, value))


def test_malformed_files(tmp_path):
    bad_yaml = tmp_path / "bad.yaml"
    bad_yaml.write_text("boundary: [[0, 0], [1, 0]\nstart: {x: 0")
    with pytest.raises(MapError, match="not valid YAML"):
        load_map(bad_yaml)
    not_a_mapping = tmp_path / "list.yaml"
    not_a_mapping.write_text("- 1\n- 2\n")
    with pytest.raises(MapError, match="mapping of fields"):
        load_map(not_a_mapping)
    with pytest.raises(MapError, match="does not exist"):
        load_map(tmp_path / "missing.yaml")
    with pytest.raises(MapError, match="not a file and not a built-in map"):
        load_map("no_such_map")


def test_map_error_is_a_value_error():
    assert issubclass(MapError, ValueError)
