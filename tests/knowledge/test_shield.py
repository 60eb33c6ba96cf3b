"""The IR safety shield: geometry at known poses, the no-collision property, batching, errors."""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest
import torch
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import symrl  # noqa: F401  (registers the env)
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.world.robot import RobotConfig

ROBOT = RobotConfig()


def _env():
    return gymnasium.make("symrl/Hailu2001-v0", noise=False).unwrapped


def _at(env, pose):
    obs, info = env.reset(seed=0, options={"pose": pose})
    return torch.from_numpy(obs["ir"]), info


def test_nothing_in_ir_range_keeps_every_action():
    shield = IRShield()
    for a in (-3.0, -0.5, 0.0, 1.2, math.pi):
        assert shield.filter(torch.zeros(24), a) == (a, False)


def test_wall_ahead_forward_is_vetoed_and_the_replacement_does_not_collide():
    env = _env()
    # facing the wall x = 3.5 (above the door) with 0.1 m of rim clearance: a 0.2 m move hits it
    pose = (3.5 - ROBOT.radius - 0.10, 1.0, 0.0)
    ir, _ = _at(env, pose)
    shield = IRShield()
    assert float(shield.clearance(ir, torch.tensor([0.0]))[0]) < 0.06
    safe, replaced = shield.filter(ir, 0.0)
    assert replaced and abs(safe) >= math.radians(40)  # it must turn well away from the wall
    _, _, _, _, info = env.step(np.array([safe], dtype=np.float32))
    assert not info["collision"]
    _at(env, pose)
    _, _, _, _, info = env.step(np.array([0.0], dtype=np.float32))
    assert info["collision"]  # the vetoed move would have collided


def test_turning_away_from_a_close_wall_is_kept():
    ir, _ = _at(_env(), (3.5 - ROBOT.radius - 0.10, 1.0, 0.0))
    assert IRShield().filter(ir, math.pi) == (math.pi, False)


def test_clearance_of_a_straight_move_matches_the_geometry():
    # one sensor (axis 0) sees a wall point at 0.3 m rim distance; the sector's edges are +-7.5 deg
    refl = torch.zeros(24)
    refl[0] = float(ROBOT.reflectance(0.3))
    shield = IRShield()
    rho = ROBOT.radius + 0.3
    # moving straight at it: the point on the axis ends 0.2 m closer
    assert float(shield.clearance(refl, torch.tensor([0.0]))[0]) == pytest.approx(0.1)
    # moving square to the left: the nearest approach is to the sector's left edge (+7.5 deg),
    # passed sideways at rho * sin(82.5 deg)
    expected = rho * math.sin(math.radians(82.5)) - ROBOT.radius
    got = float(shield.clearance(refl, torch.tensor([math.pi / 2]))[0])
    assert got == pytest.approx(expected, abs=1e-6)
    # moving straight away: the clearance never falls below the reading
    assert float(shield.clearance(refl, torch.tensor([math.pi]))[0]) == pytest.approx(0.3)


@settings(max_examples=150, deadline=None)
@given(
    x=st.floats(-1.2, 5.3),
    y=st.floats(-3.8, 2.2),
    heading=st.floats(-math.pi, math.pi),
    action=st.floats(-math.pi, math.pi),
)
def test_a_shielded_move_never_collides(x, y, heading, action):
    env = _env()
    clear = env.clearance(x, y) if env.world.in_free_area(x, y) else -1.0
    assume(clear - ROBOT.radius >= 0.06)  # a pose the shield may start from (not in collision)
    ir, _ = _at(env, (x, y, heading))
    safe, _ = IRShield().filter(ir, action)
    _, _, _, _, info = env.step(np.array([safe], dtype=np.float32))
    assert not info["collision"], (x, y, heading, action, safe)


def test_batched_forward_equals_the_one_sample_path():
    g = torch.Generator().manual_seed(3)
    refl = (torch.rand(64, 24, generator=g) ** 3 * 100) * (torch.rand(64, 24, generator=g) < 0.3)
    action = (torch.rand(64, generator=g) * 2 - 1) * math.pi
    shield = IRShield()
    batched, replaced = shield(refl, action)
    for i in range(64):
        one, hit = shield.filter(refl[i], float(action[i]))
        assert one == pytest.approx(float(batched[i]), abs=1e-9)
        assert hit == bool(replaced[i])
    assert 0 < int(replaced.sum()) < 64  # the sample exercises both branches


def test_a_larger_margin_vetoes_more():
    g = torch.Generator().manual_seed(5)
    refl = (torch.rand(200, 24, generator=g) ** 3 * 100) * (torch.rand(200, 24, generator=g) < 0.3)
    action = (torch.rand(200, generator=g) * 2 - 1) * math.pi
    small = IRShield(ShieldConfig(margin=0.03))(refl, action)[1].sum()
    large = IRShield(ShieldConfig(margin=0.10))(refl, action)[1].sum()
    assert int(large) > int(small)


@pytest.mark.parametrize(
    ("field", "value"), [("margin", -0.1), ("margin", float("nan")), ("resolution_deg", 0.0)]
)
def test_bad_config_names_the_field(field, value):
    with pytest.raises(ValueError, match=f"ShieldConfig.{field}"):
        ShieldConfig(**{field: value})


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.0, 100.0), min_size=24, max_size=24),
    st.lists(st.floats(0.0, 100.0), min_size=24, max_size=24),
    st.floats(-math.pi, math.pi),
)
def test_rows_far_from_walls_are_skipped_exactly(near_row, far_row, angle):
    """The batched shield only evaluates rows whose IR sees a wall within reach of one move;
    its veto is the full clearance test on every row."""
    shield = IRShield()
    far = [min(v, shield.quiet) * 0.5 for v in far_row]  # no wall within margin + step
    refl = torch.tensor([near_row, far], dtype=torch.float32)
    action = torch.full((2,), angle, dtype=torch.float64)
    _, vetoed = shield(refl, action)
    full = shield.clearance(refl, action[:, None])[:, 0] < shield.config.margin
    assert vetoed.tolist() == full.tolist()
    assert not bool(full[1])  # a row below the quiet reflectance is never unsafe


def _full_grid_search(shield: IRShield, refl: torch.Tensor, action: float) -> float:
    """The safe action by the whole candidate grid (what the search's shortcut must give)."""
    grid = shield.candidates
    room = shield.clearance(refl[None], grid[None])[0]
    safe = room >= shield.config.margin
    if not bool(safe.any()):
        return float(grid[room.argmax()])
    turn = torch.remainder(grid - action + math.pi, 2 * math.pi) - math.pi
    return float(grid[torch.where(safe, turn.abs(), torch.inf).argmin()])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_search_finds_what_the_whole_grid_gives(seed):
    """The candidate search tries the smallest turns first; its answer is the whole grid's:
    the nearest safe turn (the first of equal turns), else the widest clearance."""
    g = torch.Generator().manual_seed(seed)
    refl = (torch.rand(300, 24, generator=g) ** 3 * 100) * (torch.rand(300, 24, generator=g) < 0.3)
    action = (torch.rand(300, generator=g) * 2 - 1) * math.pi
    shield = IRShield()
    safe, replaced = shield(refl, action)
    rows = torch.nonzero(replaced).flatten().tolist()
    assert len(rows) > 20  # the sample exercises the search, near and far turns
    for i in rows:
        assert float(safe[i]) == _full_grid_search(shield, refl[i], float(action[i]))
