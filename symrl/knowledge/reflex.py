"""The fuzzy reflex of Hailu (2001) section 6.2 as a batched torch module.

Two fuzzy behaviours vote on three output sets (LEFT, FORWARD, RIGHT): obstacle avoidance
reads the sonars, goal following reads the signed goal angle. Their activation vectors are
fused with constant desirabilities (Eq. 5) and defuzzified to one crisp turning angle.
The paper gives the architecture but not the rules; the rule base here is the reconstruction
of ``research/ALGORITHM.md`` section 4, with its one crucial detail: the FL/FR rules are guarded
by "and not F", otherwise a robot facing a concave corner gets LEFT = RIGHT, the votes cancel
into "forward", and it rams the corner. The whole reflex is a few tensor operations over any
leading batch shape (fuzzy libraries that take milliseconds per inference are what we avoid).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import torch
from torch import nn

__all__ = ["OUTPUTS", "ReflexConfig", "FuzzyReflex", "parse_rule"]

OUTPUTS: tuple[str, str, str] = ("LEFT", "FORWARD", "RIGHT")
"""The output fuzzy sets, in the order of every activation vector."""

_HALF_PI = math.pi / 2


def _default_sectors() -> dict[str, tuple[int, ...]]:
    return {
        "F": (23, 0, 1),
        "FL": (2, 3, 4),
        "L": (5, 6, 7),
        "FR": (22, 21, 20),
        "R": (19, 18, 17),
    }


def _default_near() -> dict[str, tuple[float, float]]:
    return {
        "F": (0.25, 0.70),
        "FL": (0.20, 0.50),
        "FR": (0.20, 0.50),
        "L": (0.10, 0.35),
        "R": (0.10, 0.35),
    }


def _default_rules() -> tuple[str, ...]:
    return (
        "F and not FL -> LEFT",
        "F and FL and not FR -> RIGHT",
        "F and FL and FR -> LEFT",
        "FR and not F -> LEFT",
        "FL and not F -> RIGHT",
        "R -> 0.5 * LEFT",
        "L -> 0.5 * RIGHT",
    )


def _default_peaks() -> tuple[float, float, float]:
    return (_HALF_PI, 0.0, -_HALF_PI)


@dataclass
class ReflexConfig:
    """Every number of the reflex (ALGORITHM.md section 4); angles in radians, left positive."""

    sectors: dict[str, tuple[int, ...]] = field(default_factory=_default_sectors)
    """Sonar sectors by ray index (ray k points at heading + k*15 deg, CCW); a sector's
    distance is the minimum of its rays' rim distances."""

    near: dict[str, tuple[float, float]] = field(default_factory=_default_near)
    """NEAR(a, b) per sector, metres of rim distance: membership 1 at or below a, 0 at or
    above b, linear between. Every sector needs one."""

    rules: tuple[str, ...] = field(default_factory=_default_rules)
    """Obstacle-avoidance rule base, one rule a string ``"A and not B -> [w *] SET"``: AND = min,
    NOT = 1 - x, rules with the same SET combine by max, ``w`` scales the rule's strength.
    Deliberately no FORWARD rule, so avoidance is silent in free space."""

    peaks: tuple[float, float, float] = field(default_factory=_default_peaks)
    """Peaks of the output triangles (LEFT, FORWARD, RIGHT): RIGHT = tri(-pi, -pi/2, 0),
    FORWARD = tri(-pi/2, 0, pi/2), LEFT = tri(0, pi/2, pi); height defuzzification uses them."""

    goal_span: float = _HALF_PI
    """Goal-angle width of the goal-following sets: LEFT = clip(theta/span), FORWARD =
    clip(1 - |theta|/span), RIGHT = clip(-theta/span), each clipped to [0, 1]."""

    d_a: float = 0.7
    """Desirability of obstacle avoidance (Eq. 5). Must exceed d_g: with 0.5/0.5 the robot
    deadlocks in the concave corner (ALGORITHM.md section 4)."""

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
        if not isinstance(self.n_rays, int) or self.n_rays < 1:
            raise ValueError(f"ReflexConfig.n_rays must be a positive int, got {self.n_rays!r}")
        if not _finite(self.sonar_range) or self.sonar_range <= 0:
            raise ValueError(
                f"ReflexConfig.sonar_range must be a positive number, got {self.sonar_range!r}"
            )
        for name in ("d_a", "d_g"):
            value = getattr(self, name)
            if not _finite(value) or value < 0:
                raise ValueError(f"ReflexConfig.{name} must be a number >= 0, got {value!r}")
        if self.d_a + self.d_g <= 0:
            raise ValueError(
                f"ReflexConfig.d_a + d_g must be positive, got d_a={self.d_a!r}, d_g={self.d_g!r}"
            )
        if not _finite(self.goal_span) or self.goal_span <= 0:
            raise ValueError(
                f"ReflexConfig.goal_span must be a positive number, got {self.goal_span!r}"
            )
        if (
            not isinstance(self.peaks, (tuple, list))
            or len(self.peaks) != 3
            or not all(_finite(p) and -math.pi <= p <= math.pi for p in self.peaks)
        ):
            raise ValueError(
                f"ReflexConfig.peaks must be 3 numbers in [-pi, pi] (LEFT, FORWARD, RIGHT), "
                f"got {self.peaks!r}"
            )
        if not isinstance(self.sectors, dict) or not self.sectors:
            raise ValueError(f"ReflexConfig.sectors must be a non-empty dict, got {self.sectors!r}")
        for name, rays in self.sectors.items():
            if (
                not isinstance(rays, (tuple, list))
                or not rays
                or not all(isinstance(k, int) and 0 <= k < self.n_rays for k in rays)
            ):
                raise ValueError(
                    f"ReflexConfig.sectors[{name!r}] must be ray indices in [0, {self.n_rays}), "
                    f"got {rays!r}"
                )
        if not isinstance(self.near, dict):
            raise ValueError(f"ReflexConfig.near must be a dict, got {self.near!r}")
        for name in self.sectors:
            if name not in self.near:
                raise ValueError(f"ReflexConfig.near has no thresholds for sector {name!r}")
        for name, ab in self.near.items():
            if name not in self.sectors:
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
        if isinstance(self.rules, str) or not isinstance(self.rules, (tuple, list)):
            raise ValueError(f"ReflexConfig.rules must be a list of strings, got {self.rules!r}")
        for i, text in enumerate(self.rules):
            parse_rule(text, tuple(self.sectors), where=f"ReflexConfig.rules[{i}]")


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


_RULE = re.compile(r"^\s*(?P<lhs>.+?)\s*->\s*(?:(?P<w>[0-9]*\.?[0-9]+)\s*\*\s*)?(?P<set>\w+)\s*$")


def parse_rule(
    text: str, sectors: tuple[str, ...], where: str = "rule"
) -> tuple[list[tuple[str, bool]], int, float]:
    """Read ``"F and not FL -> 0.5 * LEFT"`` into ([(sector, negated)], output index, weight)."""
    m = _RULE.match(text) if isinstance(text, str) else None
    if m is None:
        raise ValueError(
            f"{where}: cannot read rule {text!r} (expected e.g. 'F and not FL -> LEFT' "
            "or 'R -> 0.5 * LEFT')"
        )
    if m["set"] not in OUTPUTS:
        raise ValueError(f"{where}: unknown output set {m['set']!r} in {text!r} (sets: {OUTPUTS})")
    weight = float(m["w"]) if m["w"] else 1.0
    if not 0 < weight <= 1:
        raise ValueError(f"{where}: weight must be in (0, 1], got {weight!r} in {text!r}")
    literals = []
    for part in re.split(r"\s+and\s+", m["lhs"]):
        words = part.split()
        negated = len(words) == 2 and words[0] == "not"
        if not (len(words) == 1 or negated) or words[-1] not in sectors:
            raise ValueError(
                f"{where}: bad antecedent {part!r} in {text!r} "
                f"(expected a sector or 'not' sector; sectors: {sectors})"
            )
        literals.append((words[-1], negated))
    return literals, OUTPUTS.index(m["set"]), weight


class FuzzyReflex(nn.Module):
    """``reflex(sonar (..., n_rays) in [0, 1], goal_angle (...)) -> crisp angle (...)``.

    Config compiled to buffers (S sectors, K rules, N rays; numbers kept in float64 and cast
    to the input's dtype, so float32 observations and float64 tests both compute exactly):
      ``sector_mask`` (S, N) bool, ``near_ab`` (S, 2), ``pos``/``neg`` (K, S) bool literals,
      ``rule_out`` (K, 3) rule weight on its output set, ``peaks`` (3,).
    """

    sector_mask: torch.Tensor
    near_ab: torch.Tensor
    pos: torch.Tensor
    neg: torch.Tensor
    rule_out: torch.Tensor
    peaks: torch.Tensor

    def __init__(self, config: ReflexConfig | None = None) -> None:
        super().__init__()
        config = ReflexConfig() if config is None else config
        if not isinstance(config, ReflexConfig):
            raise TypeError(f"FuzzyReflex: config must be a ReflexConfig, got {config!r}")
        config.validate()
        self.config = config
        names = tuple(config.sectors)
        self.sector_names = names
        n_s, n_k = len(names), len(config.rules)
        mask = torch.zeros(n_s, config.n_rays, dtype=torch.bool)
        for s, name in enumerate(names):
            mask[s, list(config.sectors[name])] = True
        pos = torch.zeros(n_k, n_s, dtype=torch.bool)
        neg = torch.zeros(n_k, n_s, dtype=torch.bool)
        rule_out = torch.zeros(n_k, 3, dtype=torch.float64)
        for k, text in enumerate(config.rules):
            literals, out, weight = parse_rule(text, names, where=f"ReflexConfig.rules[{k}]")
            for name, negated in literals:
                (neg if negated else pos)[k, names.index(name)] = True
            rule_out[k, out] = weight
        self.register_buffer("sector_mask", mask)
        self.register_buffer(
            "near_ab", torch.tensor([config.near[n] for n in names], dtype=torch.float64)
        )
        self.register_buffer("pos", pos)
        self.register_buffer("neg", neg)
        self.register_buffer("rule_out", rule_out)
        self.register_buffer("peaks", torch.tensor(config.peaks, dtype=torch.float64))

    # --- the two behaviours -----------------------------------------------------------------

    def near(self, sonar: torch.Tensor) -> torch.Tensor:
        """NEAR membership of every sector ``(..., S)`` from normalised sonars ``(..., N)``."""
        dist = sonar * self.config.sonar_range
        # Sector distance = min over its rays; rays outside the sector count as +inf.
        masked = torch.where(self.sector_mask, dist.unsqueeze(-2), torch.inf)
        sector = masked.amin(dim=-1)
        ab = self.near_ab.to(dist.dtype)
        a, b = ab[:, 0], ab[:, 1]
        return ((b - sector) / (b - a)).clamp(0.0, 1.0)

    def avoid(self, sonar: torch.Tensor) -> torch.Tensor:
        """Obstacle-avoidance activations ``(..., 3)``: min for AND, 1 - x for NOT, max per set."""
        mu = self.near(sonar).unsqueeze(-2)  # (..., 1, S)
        literal = torch.where(self.pos, mu, torch.where(self.neg, 1.0 - mu, 1.0))  # (..., K, S)
        strength = literal.amin(dim=-1)  # (..., K)
        return (strength.unsqueeze(-1) * self.rule_out.to(strength.dtype)).amax(dim=-2)

    def follow(self, goal_angle: torch.Tensor) -> torch.Tensor:
        """Goal-following activations ``(..., 3)`` from the signed goal angle (left positive).

        The angle is wrapped to [-pi, pi] first, so 3*pi/2 reads as a right turn of pi/2.
        """
        wrapped = torch.atan2(torch.sin(goal_angle), torch.cos(goal_angle))
        t = wrapped / self.config.goal_span
        return torch.stack(
            [t.clamp(0.0, 1.0), (1.0 - t.abs()).clamp(0.0, 1.0), (-t).clamp(0.0, 1.0)], dim=-1
        )

    # --- fusion and defuzzification ---------------------------------------------------------

    def fused(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> torch.Tensor:
        """alpha_f = d_a * alpha_a + d_g * alpha_g (Eq. 5): ``(..., 3)`` (LEFT, FORWARD, RIGHT)."""
        sonar, goal_angle = self._check(sonar, goal_angle)
        return self.config.d_a * self.avoid(sonar) + self.config.d_g * self.follow(goal_angle)

    def forward(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> torch.Tensor:
        """Height defuzzification: sum(alpha_f * peak) / sum(alpha_f); 0 (ahead) if all silent."""
        f = self.fused(sonar, goal_angle)
        total = f.sum(dim=-1)
        angle = (f * self.peaks.to(f.dtype)).sum(dim=-1) / total.clamp_min(1e-12)
        return torch.where(total > 0, angle, torch.zeros_like(angle))

    def _check(
        self, sonar: torch.Tensor, goal_angle: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        if not isinstance(sonar, torch.Tensor) or not sonar.is_floating_point():
            raise ValueError(f"FuzzyReflex: sonar must be a float tensor, got {type(sonar)}")
        if sonar.dim() < 1 or sonar.shape[-1] != self.config.n_rays:
            raise ValueError(
                f"FuzzyReflex: sonar must have shape (..., {self.config.n_rays}), "
                f"got {tuple(sonar.shape)}"
            )
        goal_angle = torch.as_tensor(goal_angle, dtype=sonar.dtype, device=sonar.device)
        try:
            batch = torch.broadcast_shapes(sonar.shape[:-1], goal_angle.shape)
        except RuntimeError:
            raise ValueError(
                f"FuzzyReflex: goal_angle shape {tuple(goal_angle.shape)} does not match the "
                f"sonar batch shape {tuple(sonar.shape[:-1])}"
            ) from None
        if not (bool(torch.isfinite(sonar).all()) and bool(torch.isfinite(goal_angle).all())):
            raise ValueError("FuzzyReflex: sonar or goal_angle contains a non-finite value")
        return sonar.expand(*batch, sonar.shape[-1]), goal_angle.expand(batch)

    def extra_repr(self) -> str:
        c = self.config
        return f"sectors={list(self.sector_names)}, rules={len(c.rules)}, d_a={c.d_a}, d_g={c.d_g}"
