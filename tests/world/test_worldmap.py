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
from symrl.world.worldmap import SUITES, builtin_maps, suite_maps

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
        regions={
            "names": ["west", "east"],
            "lines": {"mid": {"x": 2.0}},
            "rules": [{"region": "west", "when": ["x < mid"]}, {"region": "east"}],
        },
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


def _door_post_y(y: float) -> list[list[float]]:
    """The paper's boundary with the lower door post moved to ``y`` (the door spans y..0)."""
    world = yaml.safe_load(MAP_FILE.read_text())["boundary"]
    return [[x, y if (x, py) in ((3.5, -1.0), (3.75, -1.0)) else py] for x, py in world]


MEANINGLESS_MAPS = [
    (
        "door closed by a thin wall",
        "segments",
        [[[3.5, -1.0], [3.5, 0.0]]],
        r"'goal'.*cannot be reached from the start.*body",
    ),
    (
        "door narrower than the body",
        "boundary",
        _door_post_y(-0.45),
        r"'goal'.*cannot be reached from the start",
    ),
    ("start against a wall", "start", {"x": -1.4, "y": 0.0}, r"'start'.*0\.100 m.*radius"),
    ("goal disc covers the start", "goal", {"x": 0.2, "y": 0.0, "radius": 0.4}, "covers the start"),
    (
        "obstacle outside the boundary",
        "obstacles",
        [[[10, 10], [11, 10], [11, 11]]],
        r"'obstacles\[0\]'.*not inside the boundary",
    ),
    (
        "obstacle across the boundary",
        "obstacles",
        [[[-2, 0], [-1, 0], [-1, 1]]],
        r"'obstacles\[0\]'.*not inside the boundary",
    ),
    ("thin wall leaving the map", "segments", [[[0, 0], [0, 9]]], r"'segments\[0\]'.*leaves"),
    ("region line outside the map", "regions.lines.l1", {"y": 9.0}, r"'regions.lines.l1'.*outside"),
    (
        "rule shadowed by an earlier rule",
        "regions.rules",
        [
            {"region": "corridor", "when": ["x > l3"]},
            {"region": "room", "when": ["x > l3", "y < l1"]},
            {"region": "concave", "when": ["x < l3", "y < l1"]},
            {"region": "room", "when": ["x < l2"]},
            {"region": "door"},
        ],
        r"'regions.rules\[1\]'.*'room'.*never fire.*earlier rules",
    ),
    (
        "rule matching no free point",
        "regions.rules",
        [
            {"region": "corridor", "when": ["x > l3"]},
            {"region": "room", "when": ["x < l2", "x > l3"]},
            {"region": "concave", "when": ["x < l3", "y < l1"]},
            {"region": "room", "when": ["x < l2"]},
            {"region": "door"},
        ],
        r"'regions.rules\[1\]'.*never fire.*no free point",
    ),
    (
        "default rule never reached",
        "regions.rules",
        [
            {"region": "corridor", "when": ["x > l2"]},
            {"region": "concave", "when": ["x < l3", "y < l1"]},
            {"region": "room", "when": ["x < l2"]},
            {"region": "door"},
        ],
        r"'regions.rules\[3\]'.*'door'.*never fire",
    ),
    ("absurd coordinate", "boundary.0", [1e5, -2.5], r"'boundary\[0\]\[0\]'.*100000.*absurd"),
    ("absurd goal radius", "goal.radius", 2e4, r"'goal.radius'.*absurd"),
]


@pytest.mark.parametrize(
    ("fault", "path", "value", "message"), MEANINGLESS_MAPS, ids=[b[0] for b in MEANINGLESS_MAPS]
)
def test_map_without_meaning_is_rejected_naming_the_fault(doc, fault, path, value, message):
    with pytest.raises(MapError, match=message) as err:
        load_map(_mutate(doc, path, value))
    assert "\n" not in str(err.value)  # one line


def test_closed_polygon_is_the_same_map(doc):
    closed = _mutate(doc, "boundary", doc["boundary"] + [doc["boundary"][0]])
    np.testing.assert_array_equal(load_map(closed).boundary, load_map(doc).boundary)


def test_a_3000_point_boundary_validates():
    """(Its speed, about 0.1 CPU-s here, is measured by benchmarks/bench_env.py.)"""
    n = 3000
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r = 10 + 0.5 * np.sin(7 * t)
    data = {
        "name": "wobbly",
        "boundary": np.round(np.stack([r * np.cos(t), r * np.sin(t)], 1), 6).tolist(),
        "start": {"x": 0.0, "y": 0.0},
        "goal": {"x": 3.0, "y": 0.0, "radius": 0.4},
        "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
    }
    world = load_map(data)
    assert len(world.boundary) == n
    assert bool(world.contains_xy(3.0, 0.0)) and not bool(world.contains_xy(10.6, 0.0))


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
    with pytest.raises(MapError, match="is a directory"):
        load_map(tmp_path)
    binary = tmp_path / "map.yaml"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR")
    with pytest.raises(MapError, match=r"map.yaml' is a binary file"):
        load_map(binary)
    latin1 = tmp_path / "latin1.yaml"
    latin1.write_bytes("name: caf\u00e9\n".encode("latin-1"))
    with pytest.raises(MapError, match=r"latin1.yaml' is not UTF-8.*0xe9"):
        load_map(latin1)
    with pytest.raises(MapError, match="not valid YAML") as err:
        load_map(bad_yaml)
    assert "\n" not in str(err.value)


def test_map_error_is_a_value_error():
    assert issubclass(MapError, ValueError)


@pytest.mark.parametrize("name", builtin_maps())
def test_regions_of_many_points_equals_region_of_each(name):
    world = load_map(name)
    xmin, xmax, ymin, ymax = world.bounds
    rng = np.random.default_rng(0)
    x, y = rng.uniform(xmin - 1, xmax + 1, 2000), rng.uniform(ymin - 1, ymax + 1, 2000)
    lines = [c.threshold for rule in world.regions.rules for c in rule.conditions]
    x[: len(lines)] = lines  # points on the region lines themselves
    y[len(lines) : 2 * len(lines)] = lines

    def first_match(p: tuple[float, float]) -> str:  # the rules read literally, one point
        return next(
            rule.region
            for rule in world.regions.rules
            if all(
                p[c.axis] > c.threshold if c.greater else p[c.axis] < c.threshold
                for c in rule.conditions
            )
        )

    expected = [first_match((float(a), float(b))) for a, b in zip(x, y, strict=True)]
    assert world.regions.regions_of(x, y) == expected
    one_by_one = [world.regions.region_of(float(x[i]), float(y[i])) for i in range(50)]
    assert one_by_one == expected[:50]


SUITE_WORLDS = [name for suite in SUITES for name in suite_maps(suite)]


def test_the_suites_ship_their_worlds_and_a_bad_suite_is_named():
    assert len(suite_maps("tuning")) >= 19 and len(suite_maps("check")) >= 25
    assert "tuning/long_wall" in suite_maps("tuning") and "check/pillars" in suite_maps("check")
    assert load_map("tuning/long_wall").name == "long_wall"
    assert not set(builtin_maps()) & {n.split("/")[1] for n in SUITE_WORLDS}  # names stay apart
    with pytest.raises(MapError, match="suite 'tunings': unknown; the suites are tuning, check"):
        suite_maps("tunings")
    with pytest.raises(MapError, match=r"map 'tuning/nope': not a file .* suites: tuning/NAME"):
        load_map("tuning/nope")


@pytest.mark.parametrize("name", SUITE_WORLDS)
def test_every_suite_world_loads_says_what_it_tests_and_its_goal_can_be_reached(name):
    from symrl.knowledge.planner import shortest_path

    text = (resources.files("symrl.world") / "maps" / f"{name}.yaml").read_text()
    assert text.startswith("# "), "a header comment: what the world tests"
    world = load_map(name)
    plan = shortest_path(world)
    assert plan.length > 0 and math.dist(plan.points[-1], (world.goal.x, world.goal.y)) <= 0.5
