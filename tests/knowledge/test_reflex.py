"""The fuzzy reflex on hand-made sonar patterns, with hand-computed outputs
(docs/explanation/algorithm.md §4).

Default config: NEAR_F(0.25, 0.70), NEAR_FL/FR(0.20, 0.50), NEAR_L/R(0.10, 0.35) metres,
d_a = 0.7, d_g = 0.3, peaks (LEFT, FORWARD, RIGHT) = (pi/2, 0, -pi/2), sonar_range 5 m.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge import FuzzyReflex, ReflexConfig

PI = math.pi
F, FL, L, FR, R = [23, 0, 1], [2, 3, 4], [5, 6, 7], [22, 21, 20], [19, 18, 17]


@pytest.fixture(scope="module")
def reflex() -> FuzzyReflex:
    return FuzzyReflex(ReflexConfig())


def sonar(**metres: float) -> torch.Tensor:
    """Free space (5 m everywhere) with whole sectors set to a rim distance in metres."""
    s = torch.ones(24, dtype=torch.float64)
    rays = {"F": F, "FL": FL, "L": L, "FR": FR, "R": R}
    for name, d in metres.items():
        s[rays[name]] = d / 5.0
    return s


def corner_sonar(x: float, y: float, heading: float, walls: list[tuple[str, float]]):
    """Rim distances of thin rays from (x, y) to infinite walls ``x = c`` / ``y = c``."""
    ang = heading + torch.arange(24, dtype=torch.float64) * math.radians(15)
    dist = torch.full((24,), math.inf, dtype=torch.float64)
    for axis, c in walls:
        comp = torch.cos(ang) if axis == "x" else torch.sin(ang)
        t = (c - (x if axis == "x" else y)) / comp
        dist = torch.where(t > 0, torch.minimum(dist, t), dist)
    return ((dist - 0.26) / 5.0).clamp(0.0, 1.0)


def angle(reflex: FuzzyReflex, s: torch.Tensor, goal: float) -> float:
    return float(reflex(s, torch.tensor(goal, dtype=s.dtype)))


# --- free space: goal following alone ---------------------------------------------------------


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        (0.0, 0.0),
        # goal sets (1/2, 1/2, 0) -> fused 0.3*(1/2, 1/2, 0) -> (0.15*pi/2)/0.3 = pi/4
        (PI / 4, PI / 4),
        # (2/3, 1/3, 0): (2/3 * pi/2) / 1 = pi/3; mirrored to the right
        (-PI / 3, -PI / 3),
        # beyond pi/2 only LEFT (or RIGHT) fires: the turn saturates at the peak
        (3 * PI / 4, PI / 2),
        (-3 * PI / 4, -PI / 2),
    ],
)
def test_free_space_is_goal_following_only(reflex, goal, expected):
    assert angle(reflex, sonar(), goal) == pytest.approx(expected, abs=1e-12)


def test_avoidance_is_silent_in_free_space(reflex):
    free = sonar()
    assert reflex.avoid(free).tolist() == [0.0, 0.0, 0.0]
    goal = torch.tensor(PI / 4, dtype=torch.float64)
    assert reflex.fused(free, goal).tolist() == pytest.approx([0.15, 0.15, 0.0])


def test_goal_angle_is_wrapped(reflex):
    # 3*pi/2 is the same direction as -pi/2: a full right turn
    assert angle(reflex, sonar(), 3 * PI / 2) == pytest.approx(-PI / 2)


# --- walls --------------------------------------------------------------------------------


def test_symmetric_wall_ahead_turns_to_the_goals_side(reflex):
    # F at 0.25 m -> NEAR 1; FL/FR at 0.44 m -> NEAR 0.2 each: the sides tie, so the goal's
    # side decides. Goal at +0.1 rad: SIDE_L = 1, F&SIDE_L -> LEFT = 1; goal sets
    # (t, 1 - t, 0) with t = 0.2/pi -> fused (0.7 + 0.3t, 0.3(1 - t), 0), sum 1
    s = sonar(F=0.25, FL=0.44, FR=0.44)
    t = 0.1 / (PI / 2)
    assert reflex.side(s, 0.1).tolist() == [1.0, 0.0]
    assert reflex.avoid(s, 0.1).tolist() == [1.0, 0.0, 0.0]
    assert angle(reflex, s, 0.1) == pytest.approx((0.7 + 0.3 * t) * PI / 2)
    assert angle(reflex, s, -0.1) == -angle(reflex, s, 0.1)  # mirrored: to the right
    # goal dead ahead: every key ties, SIDE = (0.5, 0.5), and the output is 0 by symmetry
    assert reflex.side(s, 0.0).tolist() == [0.5, 0.5]
    assert angle(reflex, s, 0.0) == 0.0


def test_wall_ahead_turns_to_the_freer_side_even_against_the_goal(reflex):
    # F and FL near, FR free: the right is freer, F&SIDE_R -> RIGHT = 1 whatever the goal's
    # side; goal at +pi/4 adds 0.3 * (1/2, 1/2, 0): fused (0.15, 0.15, 0.7) -> -0.275 pi
    s = sonar(F=0.2, FL=0.2)
    assert angle(reflex, s, 0.0) == pytest.approx(-0.35 * PI)
    assert angle(reflex, s, PI / 4) == pytest.approx(-0.275 * PI)
    # the front-side sectors tie (both free) but L is near: the right is freer
    s = sonar(F=0.2, L=0.1)
    assert reflex.side(s, PI / 4).tolist() == [0.0, 1.0]


def test_wall_on_the_left_turns_right(reflex):
    # L at 0.10 m -> NEAR 1 -> 0.5 RIGHT; fused (0, 0.3, 0.35) -> -0.35*(pi/2)/0.65 = -7 pi/26
    assert angle(reflex, sonar(L=0.10), 0.0) == pytest.approx(-7 * PI / 26)
    # FL near too (and F clear): FL&!F -> RIGHT = 1; fused (0, 0.3, 0.7) -> -0.35 pi
    assert angle(reflex, sonar(L=0.10, FL=0.20), 0.0) == pytest.approx(-0.35 * PI)


def test_wall_on_the_right_turns_left(reflex):
    assert angle(reflex, sonar(R=0.10), 0.0) == pytest.approx(7 * PI / 26)
    assert angle(reflex, sonar(R=0.10, FR=0.20), 0.0) == pytest.approx(0.35 * PI)


def test_doorway_goes_roughly_forward(reflex):
    # L and R near, F clear: 0.5 LEFT and 0.5 RIGHT cancel -> fused (0.35, 0.3, 0.35) -> 0
    s = sonar(L=0.10, R=0.10)
    assert angle(reflex, s, 0.0) == pytest.approx(0.0, abs=1e-12)
    # goal at pi/4 adds 0.3 * (1/2, 1/2, 0): (0.50, 0.15, 0.35), sum 1 -> 0.15 * pi/2 (13.5 deg)
    assert angle(reflex, s, PI / 4) == pytest.approx(0.15 * PI / 2)


def test_concave_corner_turns_hard_not_forward(reflex):
    # F, FL and FR all fully near (facing a corner), goal at +pi/4: the sides tie, the goal's
    # side decides; only F&SIDE_L -> LEFT fires; fused (0.85, 0.15, 0) -> 0.425 pi
    s = sonar(F=0.25, FL=0.20, FR=0.20)
    assert reflex.avoid(s, PI / 4).tolist() == [1.0, 0.0, 0.0]
    assert angle(reflex, s, PI / 4) == pytest.approx(0.425 * PI)
    # goal at -pi/4: the same turn to the right (never LEFT = RIGHT cancelling to forward)
    assert reflex.avoid(s, -PI / 4).tolist() == [0.0, 0.0, 1.0]
    assert angle(reflex, s, -PI / 4) == pytest.approx(-0.425 * PI)


@pytest.mark.parametrize("goal", [0.3, -0.3, 2.5, -2.5])
def test_a_slightly_uneven_blocked_front_still_turns_decisively(reflex, goal):
    # The turning side is crisp: avoidance 1 on one set, 0 on the other, never a
    # near-cancelling LEFT ~ RIGHT. The left 4 cm freer (NEAR 0.133 apart > side_margin 0.1):
    # LEFT whatever the goal's side.
    s = sonar(F=0.25, FL=0.34, FR=0.30)
    assert reflex.avoid(s, goal).tolist() == [1.0, 0.0, 0.0]
    assert angle(reflex, s, goal) > 0.3 * PI / 2
    # 1 cm (sonar noise, NEAR 0.033 apart) is a tie: the goal's side, just as decisively
    s = sonar(F=0.25, FL=0.31, FR=0.30)
    toward = 1.0 if goal > 0 else -1.0
    assert reflex.avoid(s, goal).tolist() == ([1.0, 0.0, 0.0] if goal > 0 else [0.0, 0.0, 1.0])
    assert toward * angle(reflex, s, goal) > 0.3 * PI / 2


UNGUARDED = (
    "F and SIDE_L -> LEFT",
    "F and SIDE_R -> RIGHT",
    "FR -> LEFT",
    "FL -> RIGHT",
    "R -> 0.5 * LEFT",
    "L -> 0.5 * RIGHT",
)


def test_concave_corner_trap_without_the_not_f_guards():
    # The trap of docs/explanation/algorithm.md §4: without "and not F", FR -> LEFT and
    # FL -> RIGHT both fire,
    # avoid (1, 0, 1), fused (0.7, 0.15, 0.85), sum 1.7 -> -0.15 * (pi/2) / 1.7 = -0.044 pi:
    # almost straight into the corner (the guarded base turns 0.425 pi right, test above).
    trap = FuzzyReflex(ReflexConfig(rules=UNGUARDED))
    s = sonar(F=0.25, FL=0.20, FR=0.20)
    assert trap.avoid(s, -PI / 4).tolist() == [1.0, 0.0, 1.0]
    assert angle(trap, s, -PI / 4) == pytest.approx(-0.15 * (PI / 2) / 1.7)


def test_real_concave_corner_of_the_map(reflex):
    # Robot at (3.0, -2.0) facing the room's lower-right corner (3.5, -2.5), heading -pi/4;
    # the goal (4, -2) lies at +pi/4 relative to the heading. Thin rays to the two walls.
    s = corner_sonar(3.0, -2.0, -PI / 4, [("x", 3.5), ("y", -2.5)])
    assert float(s[0] * 5) == pytest.approx(math.sqrt(0.5) - 0.26)  # diagonal into the corner
    guarded = angle(reflex, s, PI / 4)
    unguarded = angle(FuzzyReflex(ReflexConfig(rules=UNGUARDED)), s, PI / 4)
    assert guarded > PI / 4  # a clear left turn, away from the corner
    assert abs(unguarded) < PI / 18  # the trap: votes cancel to within 10 deg of forward


# --- mirror symmetry ------------------------------------------------------------------------

MIRROR = [(-k) % 24 for k in range(24)]  # ray k (heading + 15k deg) <-> ray -k


@pytest.mark.parametrize("config", ["literal", "paper_map"])
@settings(max_examples=300, deadline=None)
@given(
    s=st.lists(st.floats(0.0, 0.3) | st.just(1.0), min_size=24, max_size=24),
    goal=st.floats(-2 * PI, 2 * PI),
)
def test_mirrored_input_gives_exactly_the_negated_output(config, s, goal):
    # Exact (==, not approx) at every input, on both paths: no side is preferred. At an exactly
    # mirror-symmetric input (a mirrored ring and goal 0) this forces the output to 0.
    reflex = _mirror_reflex(config)
    sonar_ = torch.tensor(s, dtype=torch.float64)
    mirrored = sonar_[MIRROR]
    assert reflex.angle(mirrored, -goal) == -reflex.angle(sonar_, goal)
    batch = torch.stack((sonar_, mirrored))
    out = reflex(batch, torch.tensor([goal, -goal], dtype=torch.float64))
    assert float(out[1]) == -float(out[0])
    symmetric = torch.maximum(sonar_, mirrored)
    assert reflex.angle(symmetric, 0.0) == 0.0


@functools.cache
def _mirror_reflex(config: str) -> FuzzyReflex:
    from symrl.learner.config import load_config

    return FuzzyReflex(load_config("paper_map").reflex if config == "paper_map" else None)


@settings(max_examples=200, deadline=None)
@given(
    s=st.lists(st.floats(0.0, 0.3) | st.just(1.0), min_size=24, max_size=24),
    goal=st.floats(-2 * PI, 2 * PI),
    k=st.sampled_from([0.5, 0.25, 0.8]),
)
def test_scaling_the_side_peaks_scales_every_turn(s, goal, k):
    # Height defuzzification is the activation-weighted mean of the peaks, and FORWARD's peak is
    # 0: LEFT / RIGHT at k * 90 deg give k times the 90-deg output at every input, which is what
    # `paper`'s 45-deg sets (k = 0.5) rely on (its turns are the literal reflex's, halved).
    sonar_ = torch.tensor(s, dtype=torch.float64)
    full = FuzzyReflex(ReflexConfig())
    scaled = FuzzyReflex(ReflexConfig(peaks=(k * PI / 2, 0.0, -k * PI / 2)))
    assert scaled.angle(sonar_, goal) == pytest.approx(k * full.angle(sonar_, goal), abs=1e-12)


def test_symmetric_wall_ahead_no_longer_turns_left():
    # The rule base before the turning side ("F and not FL -> LEFT", "F and FL and FR -> LEFT")
    # turned 0.21 pi LEFT here with the goal dead ahead; the mirror-symmetric one goes on to 0.
    s = sonar(F=0.25, FL=0.44, FR=0.44)
    assert angle(FuzzyReflex(), s, 0.0) == 0.0


# --- batching and range --------------------------------------------------------------------


def test_batched_equals_per_sample(reflex):
    g = torch.Generator().manual_seed(0)
    s = torch.rand(4, 5, 24, generator=g) * 0.2  # 0..1 m: every sector somewhere on its ramp
    goals = (torch.rand(4, 5, generator=g) * 2 - 1) * PI
    out = reflex(s, goals)
    fused = reflex.fused(s, goals)
    assert out.shape == (4, 5)
    assert fused.shape == (4, 5, 3)
    for i in range(4):
        for j in range(5):
            assert out[i, j] == pytest.approx(float(reflex(s[i, j], goals[i, j])), abs=1e-6)
            assert torch.allclose(fused[i, j], reflex.fused(s[i, j], goals[i, j]))


def test_goal_angle_broadcasts_and_keeps_dtype(reflex):
    s = torch.ones(3, 24)
    out = reflex(s, torch.tensor(0.0))
    assert out.shape == (3,)
    assert out.dtype == torch.float32
    assert reflex(s.double(), 0.0).dtype == torch.float64


@settings(max_examples=200, deadline=None)
@given(
    s=st.lists(st.floats(0.0, 1.0), min_size=24, max_size=24),
    goal=st.floats(-PI, PI),
)
def test_output_is_a_finite_angle_in_range(reflex, s, goal):
    out = angle(reflex, torch.tensor(s, dtype=torch.float64), goal)
    assert math.isfinite(out)
    assert -PI <= out <= PI


def test_no_goal_following_and_free_space_goes_straight():
    quiet = FuzzyReflex(ReflexConfig(d_g=0.0))
    assert angle(quiet, sonar(), PI / 2) == 0.0


# --- config validation ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"d_a": -0.1}, r"d_a must be a number >= 0, got -0.1"),
        ({"d_a": 0.0, "d_g": 0.0}, "d_a=0.0 must exceed d_g=0.0"),
        ({"d_a": 0.3, "d_g": 0.7}, "d_a=0.3 must exceed d_g=0.7"),
        ({"rules": ()}, "rules must hold at least one rule"),
        ({"side": ()}, "side must hold at least one key"),
        ({"sonar_range": 0.0}, "sonar_range must be a positive number, got 0.0"),
        ({"goal_span": float("nan")}, "goal_span"),
        ({"peaks": (1.0, 0.0)}, "peaks must be 3 numbers"),
        ({"sectors": {"F": (0, 24)}, "near": {"F": (0.1, 0.2)}}, r"sectors\['F'\]"),
        ({"near": {"F": (0.7, 0.25)}}, r"near has no thresholds for sector 'FL'"),
        ({"rules": ("F -> UP",)}, r"rules\[0\]: unknown output set 'UP'"),
        ({"rules": ("F and X -> LEFT",)}, r"rules\[0\]: bad antecedent 'X'"),
        ({"rules": ("F => LEFT",)}, r"rules\[0\]: cannot read rule"),
        ({"rules": ("F -> 2 * LEFT",)}, r"weight must be in \(0, 1\], got 2.0"),
        ({"rules": "F -> LEFT"}, "rules must be a list of strings"),
        ({"side": ("FL/XX",)}, r"side: bad key 'FL/XX'"),
        ({"side": ("goal", "goal")}, "side: a key appears twice"),
        ({"side": "goal"}, "side must be a list of keys"),
        ({"side_margin": 1.0}, r"side_margin must be a number in \[0, 1\), got 1.0"),
    ],
)
def test_bad_config_names_the_field(changes, message):
    with pytest.raises(ValueError, match=message):
        ReflexConfig(**changes)


def test_bad_near_thresholds_name_the_sector():
    near = dict(ReflexConfig().near, F=(0.7, 0.25))
    with pytest.raises(ValueError, match=r"near\['F'\] must be \(a, b\) with 0 <= a < b"):
        ReflexConfig(near=near)


def test_every_config_field_is_documented():
    import inspect

    source = inspect.getsource(ReflexConfig)
    for f in dataclasses.fields(ReflexConfig):
        after = source.split(f"    {f.name}:", 1)[1]
        assert '"""' in after.split("\n")[1], f"field {f.name} has no docstring"


@pytest.mark.parametrize(
    ("sonar_shape", "goal_shape", "message"),
    [
        ((24,), (), None),
        ((3, 23), (3,), r"shape \(\.\.\., 24\), got \(3, 23\)"),
        ((3, 24), (4,), "does not match the sonar batch shape"),
    ],
)
def test_bad_inputs_raise_clear_errors(reflex, sonar_shape, goal_shape, message):
    s, g = torch.ones(sonar_shape), torch.zeros(goal_shape)
    if message is None:
        reflex(s, g)
    else:
        with pytest.raises(ValueError, match=message):
            reflex(s, g)
    with pytest.raises(ValueError, match="non-finite"):
        reflex(torch.full((24,), float("nan")), torch.tensor(0.0))


def test_public_names_import_from_the_reflex_package():
    """Callers import the reflex's names from ``symrl.knowledge.reflex`` itself."""
    from symrl.knowledge import reflex

    for name in ("OUTPUTS", "SIDES", "ReflexConfig", "FuzzyReflex", "check_finite", "parse_rule"):
        assert name in reflex.__all__ and hasattr(reflex, name), name
    assert reflex.FuzzyReflex is FuzzyReflex and reflex.ReflexConfig is ReflexConfig
    assert reflex.parse_rule("F and not FL -> 0.5 * LEFT", ("F", "FL")) == (
        [("F", False), ("FL", True)],
        reflex.OUTPUTS.index("LEFT"),
        0.5,
    )
