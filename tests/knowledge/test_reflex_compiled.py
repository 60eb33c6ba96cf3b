"""The compiled reflex computes the same numbers, bit for bit, as the rule base written out
directly (the original tensor formulation, kept here as the oracle), on the batched tensor path
and on the single-sample float path the learner calls."""

from __future__ import annotations

import math

import pytest
import torch

from symrl.knowledge import FuzzyReflex, ReflexConfig

PI = math.pi
CUSTOM_RULES = (
    "F and not F -> LEFT",  # a sector both positive and negated: the positive literal wins
    "FR and not FL and L -> 0.3 * RIGHT",
    "R -> FORWARD",
    "FL and not SIDE_R -> 0.7 * LEFT",
)


def oracle(reflex: FuzzyReflex, sonar: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """The uncompiled reflex: masks over all rays and all sectors, ``torch.where`` literals."""
    cfg = reflex.config
    dist = sonar * cfg.sonar_range
    sector = torch.where(reflex.sector_mask, dist.unsqueeze(-2), torch.inf).amin(dim=-1)
    ab = reflex.near_ab.to(dist.dtype)
    mu = ((ab[:, 1] - sector) / (ab[:, 1] - ab[:, 0])).clamp(0.0, 1.0)
    wrapped = torch.atan2(torch.sin(goal), torch.cos(goal))
    # the turning side, written out: the first key (in config order) with a non-zero sign
    names = reflex.sector_names
    keys = {
        k: mu[..., names.index(k.split("/")[1])] - mu[..., names.index(k.split("/")[0])]
        for k in cfg.side
        if k != "goal"
    }
    keys = {k: torch.where(v.abs() > cfg.side_margin, v, 0.0) for k, v in keys.items()}
    keys["goal"] = wrapped
    decided = torch.zeros_like(wrapped)
    for k in reversed(cfg.side):
        decided = torch.where(keys[k] != 0, torch.sign(keys[k]), decided)
    side_l = torch.where(decided > 0, 1.0, torch.where(decided < 0, 0.0, 0.5))
    mu = torch.cat((mu, side_l.unsqueeze(-1), (1.0 - side_l).unsqueeze(-1)), dim=-1)
    mu = mu.unsqueeze(-2)
    literal = torch.where(reflex.pos, mu, torch.where(reflex.neg, 1.0 - mu, 1.0))
    strength = literal.amin(dim=-1)
    avoid = (strength.unsqueeze(-1) * reflex.rule_out.to(strength.dtype)).amax(dim=-2)
    t = wrapped / cfg.goal_span
    follow = torch.stack(
        [t.clamp(0.0, 1.0), (1.0 - t.abs()).clamp(0.0, 1.0), (-t).clamp(0.0, 1.0)], dim=-1
    )
    f = cfg.d_a * avoid + cfg.d_g * follow
    total = (f[..., 0] + f[..., 2]) + f[..., 1]  # LEFT + RIGHT first: mirror-exact rounding
    angle = (f * reflex.peaks.to(f.dtype)).sum(dim=-1) / total.clamp_min(1e-12)
    return torch.where(total > 0, angle, torch.zeros_like(angle))


def samples(n: int, dtype: torch.dtype, seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """Sonars dense on the NEAR ramps (0..1.25 m), some free space, some exactly on a threshold."""
    g = torch.Generator().manual_seed(seed)
    s = torch.rand(n, 24, generator=g, dtype=torch.float64) ** 3 * 0.25
    s[::5] = torch.rand(len(s[::5]), 24, generator=g, dtype=torch.float64)
    s[1::11] = 0.25 / 5.0  # NEAR_F's a, NEAR_FL's b... on the dot
    s[2::13, :12] = 1.0
    goal = (torch.rand(n, generator=g, dtype=torch.float64) * 2 - 1) * 3 * PI
    goal[::17] = 0.0
    return s.to(dtype), goal.to(dtype)


@pytest.mark.parametrize("rules", [None, CUSTOM_RULES])
@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_batched_path_equals_the_uncompiled_rule_base(rules, dtype):
    reflex = FuzzyReflex(ReflexConfig() if rules is None else ReflexConfig(rules=rules))
    s, goal = samples(5000, dtype)
    # a float64 (B, n) batch takes the numpy path, the (50, 100, n) view the tensor path
    assert torch.equal(reflex(s, goal), oracle(reflex, s, goal))
    assert torch.equal(
        reflex(s.view(50, 100, 24), goal.view(50, 100)), oracle(reflex, s, goal).view(50, 100)
    )


@pytest.mark.parametrize("rules", [None, CUSTOM_RULES])
def test_single_sample_float_path_equals_the_tensor_path(rules):
    reflex = FuzzyReflex(ReflexConfig() if rules is None else ReflexConfig(rules=rules))
    s, goal = samples(4000, torch.float64, seed=1)
    batched = oracle(reflex, s, goal)
    for i in range(len(s)):
        single = reflex(s[i], goal[i])  # the float path (1-D float64 sonar, 0-d goal)
        assert single.shape == () and single.dtype == torch.float64
        assert float(single) == float(oracle(reflex, s[i], goal[i])), i
        assert float(single) == pytest.approx(float(batched[i]), abs=1e-12)


def test_single_sample_rejects_non_finite_anywhere():
    reflex = FuzzyReflex()
    s = torch.ones(24, dtype=torch.float64)
    s[10] = math.inf  # a ray in no sector still counts
    with pytest.raises(ValueError, match="non-finite"):
        reflex(s, torch.tensor(0.0, dtype=torch.float64))
    with pytest.raises(ValueError, match="non-finite"):
        reflex(torch.ones(24, dtype=torch.float64), torch.tensor(math.nan, dtype=torch.float64))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 24\)"):
        reflex(torch.ones(23, dtype=torch.float64), torch.tensor(0.0, dtype=torch.float64))


def test_compiled_constants_follow_dtype_moves_and_state_dict():
    reflex = FuzzyReflex()
    s, goal = samples(200, torch.float64, seed=2)
    before = reflex(s, goal)
    assert set(reflex.state_dict()) == {"sector_mask", "near_ab", "pos", "neg", "rule_out", "peaks"}
    moved = FuzzyReflex()
    moved(s, goal)  # constants compiled for float64 ...
    moved.float()  # ... then the buffers become float32: constants are rebuilt from them
    assert moved.near_ab.dtype == torch.float32
    assert torch.equal(moved(s, goal), oracle(moved, s, goal))
    assert not torch.equal(moved(s, goal), before)  # pi/2 etc. rounded to float32
    fresh = FuzzyReflex()
    fresh.load_state_dict(reflex.state_dict())
    assert torch.equal(fresh(s, goal), before)
    # a changed buffer is picked up (constants are rebuilt after loading)
    state = reflex.state_dict()
    state["peaks"] = -state["peaks"]
    fresh.load_state_dict(state)
    assert torch.equal(fresh(s, goal), -before)
    assert float(fresh(s[0], goal[0])) == -float(before[0])


def test_angle_of_one_sample_is_the_float64_call():
    reflex = FuzzyReflex()
    s, goal = samples(2000, torch.float32, seed=3)
    for i in range(len(s)):
        g = float(goal[i])
        expected = float(reflex(s[i].double(), torch.tensor(g, dtype=torch.float64)))
        assert reflex.angle(s[i], g) == expected, i
    with pytest.raises(ValueError, match="non-finite"):
        reflex.angle(torch.ones(24), math.nan)


def test_recompile_after_editing_a_buffer_in_place():
    reflex = FuzzyReflex()
    s, goal = samples(50, torch.float64, seed=4)
    before = reflex(s, goal)
    single = reflex.angle(s[0], float(goal[0]))
    with torch.no_grad():
        reflex.peaks.neg_()
    reflex.recompile()
    assert torch.equal(reflex(s, goal), -before)
    assert reflex.angle(s[0], float(goal[0])) == -single


@pytest.mark.parametrize("side", [("goal",), ("L/R", "goal", "FL/FR"), ("goal", "FL/FR")])
def test_every_path_decides_the_turning_side_in_the_configs_key_order(side):
    """The tensor, numpy and Python-float paths read the side pairs and their order from one
    compilation: a reordered ``side`` changes all three alike, as the uncompiled oracle."""
    reflex = FuzzyReflex(ReflexConfig(side=side, side_margin=0.0))
    s, goal = samples(600, torch.float64, seed=5)
    expected = oracle(reflex, s, goal)
    assert torch.equal(reflex(s, goal), expected)  # numpy path
    assert torch.equal(reflex(s.view(20, 30, 24), goal.view(20, 30)).flatten(), expected)
    for i in range(0, len(s), 7):  # one sample against the oracle of that sample alone
        assert reflex.angle(s[i], float(goal[i])) == float(oracle(reflex, s[i], goal[i])), i
