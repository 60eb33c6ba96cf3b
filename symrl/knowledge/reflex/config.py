"""The reflex's configuration: every number of the algorithm page's section 4
(docs/explanation/algorithm.md) in one dataclass, checked
on construction so a bad recipe fails with the field's name before any robot moves."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from symrl.knowledge.reflex.rules import (
    HALF_PI,
    default_near,
    default_peaks,
    default_rules,
    default_sectors,
    default_side,
    parse_rule,
)

__all__ = ["ReflexConfig"]


@dataclass
class ReflexConfig:
    """Every number of the reflex (docs/explanation/algorithm.md section 4); angles in radians,
    left positive."""

    sectors: dict[str, tuple[int, ...]] = field(default_factory=default_sectors)
    """Sonar sectors by ray index (ray k points at heading + k*15 deg, CCW); a sector's
    distance is the minimum of its rays' rim distances."""

    near: dict[str, tuple[float, float]] = field(default_factory=default_near)
    """NEAR(a, b) per sector, metres of rim distance: membership 1 at or below a, 0 at or
    above b, linear between. Every sector needs one."""

    rules: tuple[str, ...] = field(default_factory=default_rules)
    """Obstacle-avoidance rule base, one rule a string ``"A and not B -> [w *] SET"``: AND = min,
    NOT = 1 - x, rules with the same SET combine by max, ``w`` scales the rule's strength. A
    literal is a sector (its NEAR membership) or ``SIDE_L`` / ``SIDE_R`` (the turning side, see
    ``side``). Deliberately no FORWARD rule, so avoidance is silent in free space."""

    side: tuple[str, ...] = field(default_factory=default_side)
    """How the turning side is chosen, first decisive key wins: ``"A/B"`` (a left sector / its
    mirror on the right) picks the side whose sector is less NEAR, ``"goal"`` the side of the
    goal angle; a tie falls through to the next key. ``SIDE_L`` is then 1 and ``SIDE_R`` 0 or
    the reverse (crisp, so a blocked front never splits into LEFT = RIGHT); 0.5 each only if
    every key ties, i.e. at an exactly mirror-symmetric input, whose output is 0 anyway."""

    side_margin: float = 0.1
    """A sector pair of ``side`` ties when its NEAR memberships differ by at most this, so
    sonar noise (0.01 m) does not pick the side at a symmetric corner: 0.1 is 3 cm on the
    default FL/FR ramp (0.30 m), 2.5 cm on the ``paper`` recipe's (0.25 m)."""

    peaks: tuple[float, float, float] = field(default_factory=default_peaks)
    """Peaks of the output triangles (LEFT, FORWARD, RIGHT): RIGHT = tri(-pi, -pi/2, 0),
    FORWARD = tri(-pi/2, 0, pi/2), LEFT = tri(0, pi/2, pi); height defuzzification uses them."""

    goal_span: float = HALF_PI
    """Goal-angle width of the goal-following sets: LEFT = clip(theta/span), FORWARD =
    clip(1 - |theta|/span), RIGHT = clip(-theta/span), each clipped to [0, 1]."""

    d_a: float = 0.7
    """Desirability of obstacle avoidance (Eq. 5). Must exceed d_g: with 0.5/0.5 the robot
    deadlocks in the concave corner (docs/explanation/algorithm.md section 4)."""

    d_g: float = 0.3
    """Desirability of goal following (Eq. 5)."""

    sonar_range: float = 5.0
    """Metres of the sonar reading 1.0; normalised sonars are multiplied by it."""

    n_rays: int = 24
    """Number of sonar rays the reflex expects (the last dimension of its input)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first bad field and its value."""
        _check_numbers(self)
        _check_sectors(self)
        _check_rules(self)
        _check_side(self)


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_numbers(c: ReflexConfig) -> None:
    """The scalar fields and the output peaks."""
    if not isinstance(c.n_rays, int) or c.n_rays < 1:
        raise ValueError(f"ReflexConfig.n_rays must be a positive int, got {c.n_rays!r}")
    if not _finite(c.sonar_range) or c.sonar_range <= 0:
        raise ValueError(
            f"ReflexConfig.sonar_range must be a positive number, got {c.sonar_range!r}"
        )
    for name in ("d_a", "d_g"):
        value = getattr(c, name)
        if not _finite(value) or value < 0:
            raise ValueError(f"ReflexConfig.{name} must be a number >= 0, got {value!r}")
    if c.d_a <= c.d_g:
        raise ValueError(
            f"ReflexConfig.d_a={c.d_a!r} must exceed d_g={c.d_g!r}: with avoidance no "
            "stronger than goal following the robot deadlocks in a concave corner"
        )
    if not _finite(c.goal_span) or c.goal_span <= 0:
        raise ValueError(f"ReflexConfig.goal_span must be a positive number, got {c.goal_span!r}")
    if (
        not isinstance(c.peaks, (tuple, list))
        or len(c.peaks) != 3
        or not all(_finite(p) and -math.pi <= p <= math.pi for p in c.peaks)
    ):
        raise ValueError(
            f"ReflexConfig.peaks must be 3 numbers in [-pi, pi] (LEFT, FORWARD, RIGHT), "
            f"got {c.peaks!r}"
        )


def _check_sectors(c: ReflexConfig) -> None:
    """Every sector's rays exist, and every sector has exactly one NEAR ramp."""
    if not isinstance(c.sectors, dict) or not c.sectors:
        raise ValueError(f"ReflexConfig.sectors must be a non-empty dict, got {c.sectors!r}")
    for name, rays in c.sectors.items():
        if (
            not isinstance(rays, (tuple, list))
            or not rays
            or not all(isinstance(k, int) and 0 <= k < c.n_rays for k in rays)
        ):
            raise ValueError(
                f"ReflexConfig.sectors[{name!r}] must be ray indices in [0, {c.n_rays}), "
                f"got {rays!r}"
            )
    if not isinstance(c.near, dict):
        raise ValueError(f"ReflexConfig.near must be a dict, got {c.near!r}")
    for name in c.sectors:
        if name not in c.near:
            raise ValueError(f"ReflexConfig.near has no thresholds for sector {name!r}")
    for name, ab in c.near.items():
        if name not in c.sectors:
            raise ValueError(f"ReflexConfig.near[{name!r}]: no such sector")
        if (
            not isinstance(ab, (tuple, list))
            or len(ab) != 2
            or not all(_finite(v) for v in ab)
            or not 0 <= ab[0] < ab[1]
        ):
            raise ValueError(
                f"ReflexConfig.near[{name!r}] must be (a, b) with 0 <= a < b metres, got {ab!r}"
            )


def _check_rules(c: ReflexConfig) -> None:
    """At least one rule, each readable over the config's sectors."""
    if isinstance(c.rules, str) or not isinstance(c.rules, (tuple, list)):
        raise ValueError(f"ReflexConfig.rules must be a list of strings, got {c.rules!r}")
    if not c.rules:
        raise ValueError("ReflexConfig.rules must hold at least one rule, got []")
    for i, text in enumerate(c.rules):
        parse_rule(text, tuple(c.sectors), where=f"ReflexConfig.rules[{i}]")


def _check_side(c: ReflexConfig) -> None:
    """The side margin, and side keys that are 'goal' or a pair of existing sectors."""
    if not _finite(c.side_margin) or not 0 <= c.side_margin < 1:
        raise ValueError(
            f"ReflexConfig.side_margin must be a number in [0, 1), got {c.side_margin!r}"
        )
    if isinstance(c.side, str) or not isinstance(c.side, (tuple, list)):
        raise ValueError(f"ReflexConfig.side must be a list of keys, got {c.side!r}")
    if not c.side:
        raise ValueError("ReflexConfig.side must hold at least one key (e.g. 'goal'), got []")
    if len(set(c.side)) != len(c.side):
        raise ValueError(f"ReflexConfig.side: a key appears twice in {c.side!r}")
    for key in c.side:
        pair = key.split("/") if isinstance(key, str) else None
        if key != "goal" and (
            pair is None or len(pair) != 2 or not all(p in c.sectors for p in pair)
        ):
            raise ValueError(
                f"ReflexConfig.side: bad key {key!r} (expected 'goal' or 'LEFT_SECTOR/"
                f"RIGHT_SECTOR' of sectors {tuple(c.sectors)})"
            )
