"""ReflexConfig.front_gate: goal following scaled by 1 - front_gate * NEAR_F (default 0 = Eq. 5).

Measured and not adopted (docs/LEARNING.md); these tests pin the switch so it stays available
and off by default.
"""

from __future__ import annotations

import math

import pytest
import torch

from symrl.knowledge import FuzzyReflex, ReflexConfig

F = [23, 0, 1]


def _wall_ahead(metres: float = 0.2) -> torch.Tensor:
    s = torch.ones(24, dtype=torch.float64)
    s[F] = metres / 5.0
    return s


def test_default_is_off_and_identical():
    assert ReflexConfig().front_gate == 0.0
    g = torch.Generator().manual_seed(1)
    sonar = torch.rand(200, 24, generator=g, dtype=torch.float64) * 0.2
    goal = (torch.rand(200, generator=g, dtype=torch.float64) - 0.5) * 2 * math.pi
    old = FuzzyReflex(ReflexConfig())(sonar, goal)
    new = FuzzyReflex(ReflexConfig(front_gate=0.0))(sonar, goal)
    assert torch.equal(old, new)


def test_wall_ahead_goal_behind_turns_instead_of_straight():
    # Wall ahead (NEAR_F = 1, avoidance votes LEFT 1), goal 90 deg to the right (RIGHT 1):
    # fused (0.7, 0, 0.3) with the constant d_g; with front_gate 1 goal following is silenced.
    sonar, goal = _wall_ahead(), torch.tensor(-math.pi / 2, dtype=torch.float64)
    plain = FuzzyReflex(ReflexConfig())
    gated = FuzzyReflex(ReflexConfig(front_gate=1.0))
    assert torch.allclose(plain.fused(sonar, goal), torch.tensor([0.7, 0.0, 0.3]).double())
    assert torch.allclose(gated.fused(sonar, goal), torch.tensor([0.7, 0.0, 0.0]).double())
    assert float(gated(sonar, goal)) == pytest.approx(math.pi / 2)
    half = FuzzyReflex(ReflexConfig(front_gate=0.5))
    assert torch.allclose(half.fused(sonar, goal), torch.tensor([0.7, 0.0, 0.15]).double())


def test_free_space_unchanged():
    sonar, goal = torch.ones(24, dtype=torch.float64), torch.tensor(0.4, dtype=torch.float64)
    assert float(FuzzyReflex(ReflexConfig(front_gate=1.0))(sonar, goal)) == float(
        FuzzyReflex()(sonar, goal)
    )


def test_single_sample_path_matches_batched_bit_for_bit():
    reflex = FuzzyReflex(ReflexConfig(front_gate=0.7))
    g = torch.Generator().manual_seed(0)
    sonar = torch.rand(300, 24, generator=g, dtype=torch.float64) * 0.2
    goal = (torch.rand(300, generator=g, dtype=torch.float64) - 0.5) * 2 * math.pi
    batched = reflex(sonar, goal)
    for i in range(300):
        assert float(reflex(sonar[i], goal[i])) == float(batched[i])
        assert reflex.angle(sonar[i].float(), float(goal[i])) == float(
            reflex(sonar[i].float().double(), goal[i])
        )


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), True])
def test_validation(bad):
    with pytest.raises(ValueError, match="front_gate"):
        ReflexConfig(front_gate=bad)


def test_needs_front_sector():
    sectors = {"FL": (2, 3, 4), "FR": (22, 21, 20)}
    near = {"FL": (0.2, 0.5), "FR": (0.2, 0.5)}
    rules = ("FL -> RIGHT", "FR -> LEFT")
    ReflexConfig(sectors=sectors, near=near, rules=rules)  # fine with the gate off
    with pytest.raises(ValueError, match="sector named 'F'"):
        ReflexConfig(sectors=sectors, near=near, rules=rules, front_gate=0.5)
