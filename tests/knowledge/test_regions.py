"""The region mapper against the paper's rules (section 6.1) and the map's scalar reference."""

from __future__ import annotations

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge import RegionMapper
from symrl.world.worldmap import load_map

ROOM, CONCAVE, DOOR, CORRIDOR = 0, 1, 2, 3


@pytest.fixture(scope="module")
def world():
    return load_map("hailu2001")


@pytest.fixture(scope="module")
def mapper(world):
    return RegionMapper.from_map(world)


def ids(mapper: RegionMapper, points: list[tuple[float, float]]) -> list[int]:
    return mapper(torch.tensor(points, dtype=torch.float32)).tolist()


def test_names_follow_the_map(mapper, world):
    assert mapper.names == ("room", "concave", "door", "corridor")
    assert mapper.names == world.regions.names


def test_one_point_inside_each_region(mapper):
    # start, lower-right room below l1, middle of the door, goal in the corridor
    assert ids(mapper, [(0.0, 0.0), (3.0, -2.0), (3.6, -0.5), (4.0, -2.0)]) == [
        ROOM,
        CONCAVE,
        DOOR,
        CORRIDOR,
    ]


def test_line_l1_is_strict(mapper):
    # concave needs y < -1: on l1 the pose is room, just below it is concave
    assert ids(mapper, [(1.0, -1.0), (1.0, -1.001), (1.0, -0.999)]) == [ROOM, CONCAVE, ROOM]


def test_line_l2_is_strict(mapper):
    # room needs x < 3.5: on l2 (above l1) the pose is door
    assert ids(mapper, [(3.5, -0.5), (3.499, -0.5), (3.501, -0.5)]) == [DOOR, ROOM, DOOR]


def test_line_l3_is_strict(mapper):
    # corridor needs x > 3.75 and concave needs x < 3.75: on l3 neither holds
    assert ids(mapper, [(3.75, -0.5), (3.751, -0.5), (3.749, -0.5)]) == [DOOR, CORRIDOR, DOOR]
    assert ids(mapper, [(3.75, -2.0), (3.751, -2.0), (3.749, -2.0)]) == [DOOR, CORRIDOR, CONCAVE]


def test_concave_reaches_into_the_door_columns(mapper):
    # x in [3.5, 3.75) below l1 is concave (x < l3 and y < l1), not door
    assert ids(mapper, [(3.6, -1.5)]) == [CONCAVE]


def test_heading_column_is_ignored(mapper):
    poses = torch.tensor([[0.0, 0.0, 3.0], [4.0, -2.0, -1.0]])
    assert mapper(poses).tolist() == [ROOM, CORRIDOR]


def test_batch_shapes(mapper):
    assert mapper(torch.zeros(3)).shape == ()
    out = mapper(torch.zeros(4, 5, 2))
    assert out.shape == (4, 5)
    assert out.dtype == torch.long
    assert mapper(torch.zeros(0, 2)).shape == (0,)


def test_batched_equals_one_by_one(mapper):
    g = torch.Generator().manual_seed(0)
    poses = torch.rand(7, 3, 2, generator=g) * torch.tensor([7.0, 6.5]) + torch.tensor([-1.5, -4])
    batched = mapper(poses)
    for i in range(7):
        for j in range(3):
            assert batched[i, j] == mapper(poses[i, j])


@settings(max_examples=300, deadline=None)
@given(
    points=st.lists(
        st.tuples(
            st.one_of(st.floats(-2.0, 6.0), st.sampled_from([3.5, 3.75])),
            st.one_of(st.floats(-4.5, 3.0), st.just(-1.0)),
        ),
        min_size=1,
        max_size=50,
    )
)
def test_agrees_with_the_scalar_reference(world, mapper, points):
    expected = [world.regions.names.index(world.regions.region_of(x, y)) for x, y in points]
    assert mapper(torch.tensor(points, dtype=torch.float64)).tolist() == expected


def test_float32_agrees_with_reference_at_float32_points(world, mapper):
    g = torch.Generator().manual_seed(1)
    poses = torch.rand(2000, 2, generator=g) * torch.tensor([8.0, 8.0]) - torch.tensor([2.0, 5])
    expected = [
        world.regions.names.index(world.regions.region_of(float(x), float(y)))
        for x, y in poses.tolist()
    ]
    assert mapper(poses).tolist() == expected


def test_rules_come_from_the_map():
    custom = {
        "name": "two-rooms",
        "boundary": [[0, 0], [4, 0], [4, 2], [0, 2]],
        "start": {"x": 0.5, "y": 1.0},
        "goal": {"x": 3.5, "y": 1.0, "radius": 0.3},
        "regions": {
            "names": ["west", "east", "north_east"],
            "lines": {"mid": {"x": 2.0}, "top": {"y": 1.5}},
            "rules": [
                {"region": "north_east", "when": ["x > mid", "y > top"]},
                {"region": "west", "when": ["x < mid"]},
                {"region": "east"},
            ],
        },
    }
    mapper = RegionMapper.from_map(load_map(custom))
    assert mapper.names == ("west", "east", "north_east")
    points = [(1.0, 1.8), (3.0, 1.0), (3.0, 1.8), (2.0, 1.8), (3.0, 1.5)]
    # on x = mid: not west, not north_east -> east (default); on y = top: not north_east
    assert ids(mapper, points) == [0, 1, 2, 1, 1]
    assert RegionMapper.from_map(custom).names == mapper.names


@pytest.mark.parametrize(
    ("poses", "message"),
    [
        (torch.zeros(4, 4), r"\(\.\.\., 2\) or \(\.\.\., 3\), got \(4, 4\)"),
        (torch.zeros(2, dtype=torch.long), "floating-point"),
        (torch.tensor([[float("nan"), 0.0]]), "non-finite"),
    ],
)
def test_bad_poses_raise_clear_errors(mapper, poses, message):
    with pytest.raises(ValueError, match=message):
        mapper(poses)


def test_buffers_move_with_the_module(mapper):
    assert {name for name, _ in mapper.named_buffers()} == {
        "axis",
        "greater",
        "threshold",
        "used",
        "rule_region",
        "select",
        "bound",
    }
    assert set(mapper.state_dict()) == {"axis", "greater", "threshold", "used", "rule_region"}
    assert list(mapper.parameters()) == []
