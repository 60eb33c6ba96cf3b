"""The fuzzy reflex of Hailu (2001) section 6.2 as a batched torch module.

Two fuzzy behaviours vote on three output sets (LEFT, FORWARD, RIGHT): obstacle avoidance
reads the sonars, goal following reads the signed goal angle. Their activation vectors are
fused with constant desirabilities (Eq. 5) and defuzzified to one crisp turning angle.
The paper gives the architecture but not the rules; the rule base here is the reconstruction of
``docs/explanation/algorithm.md`` section 4, with its two crucial details. The FL/FR rules are
guarded by "and not F", and a blocked front turns to ONE side, the crisp turning side ``SIDE_L``
/ ``SIDE_R`` (the freer side, else the goal's side): otherwise a robot facing a concave corner
gets LEFT = RIGHT, the votes cancel into "forward", and it rams the corner. The rule base is
mirror-symmetric: mirroring the sonar ring (ray k <-> ray -k) and negating the goal angle
negates the output exactly; no side is preferred. The whole reflex is a few tensor operations
over any leading batch shape (fuzzy libraries that take milliseconds per inference are what we
avoid).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import torch
from torch import nn

__all__ = ["OUTPUTS", "ReflexConfig", "FuzzyReflex", "parse_rule"]

OUTPUTS: tuple[str, str, str] = ("LEFT", "FORWARD", "RIGHT")
"""The output fuzzy sets, in the order of every activation vector."""

SIDES: tuple[str, str] = ("SIDE_L", "SIDE_R")
"""The crisp turning-side literals a rule may use besides the sectors (``ReflexConfig.side``)."""

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
        "F and SIDE_L -> LEFT",
        "F and SIDE_R -> RIGHT",
        "FR and not F -> LEFT",
        "FL and not F -> RIGHT",
        "R -> 0.5 * LEFT",
        "L -> 0.5 * RIGHT",
    )


def _default_side() -> tuple[str, ...]:
    return ("FL/FR", "L/R", "goal")


def _default_peaks() -> tuple[float, float, float]:
    return (_HALF_PI, 0.0, -_HALF_PI)


@dataclass
class ReflexConfig:
    """Every number of the reflex (docs/explanation/algorithm.md section 4); angles in radians,
    left positive."""

    sectors: dict[str, tuple[int, ...]] = field(default_factory=_default_sectors)
    """Sonar sectors by ray index (ray k points at heading + k*15 deg, CCW); a sector's
    distance is the minimum of its rays' rim distances."""

    near: dict[str, tuple[float, float]] = field(default_factory=_default_near)
    """NEAR(a, b) per sector, metres of rim distance: membership 1 at or below a, 0 at or
    above b, linear between. Every sector needs one."""

    rules: tuple[str, ...] = field(default_factory=_default_rules)
    """Obstacle-avoidance rule base, one rule a string ``"A and not B -> [w *] SET"``: AND = min,
    NOT = 1 - x, rules with the same SET combine by max, ``w`` scales the rule's strength. A
    literal is a sector (its NEAR membership) or ``SIDE_L`` / ``SIDE_R`` (the turning side, see
    ``side``). Deliberately no FORWARD rule, so avoidance is silent in free space."""

    side: tuple[str, ...] = field(default_factory=_default_side)
    """How the turning side is chosen, first decisive key wins: ``"A/B"`` (a left sector / its
    mirror on the right) picks the side whose sector is less NEAR, ``"goal"`` the side of the
    goal angle; a tie falls through to the next key. ``SIDE_L`` is then 1 and ``SIDE_R`` 0 or
    the reverse (crisp, so a blocked front never splits into LEFT = RIGHT); 0.5 each only if
    every key ties, i.e. at an exactly mirror-symmetric input, whose output is 0 anyway."""

    side_margin: float = 0.1
    """A sector pair of ``side`` ties when its NEAR memberships differ by at most this, so
    sonar noise (0.01 m) does not pick the side at a symmetric corner: 0.1 is 3 cm on the
    default FL/FR ramp (0.30 m), 2.5 cm on the ``paper`` recipe's (0.25 m)."""

    peaks: tuple[float, float, float] = field(default_factory=_default_peaks)
    """Peaks of the output triangles (LEFT, FORWARD, RIGHT): RIGHT = tri(-pi, -pi/2, 0),
    FORWARD = tri(-pi/2, 0, pi/2), LEFT = tri(0, pi/2, pi); height defuzzification uses them."""

    goal_span: float = _HALF_PI
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
        if self.d_a <= self.d_g:
            raise ValueError(
                f"ReflexConfig.d_a={self.d_a!r} must exceed d_g={self.d_g!r}: with avoidance no "
                "stronger than goal following the robot deadlocks in a concave corner"
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
        if not self.rules:
            raise ValueError("ReflexConfig.rules must hold at least one rule, got []")
        for i, text in enumerate(self.rules):
            parse_rule(text, tuple(self.sectors), where=f"ReflexConfig.rules[{i}]")
        if not _finite(self.side_margin) or not 0 <= self.side_margin < 1:
            raise ValueError(
                f"ReflexConfig.side_margin must be a number in [0, 1), got {self.side_margin!r}"
            )
        if isinstance(self.side, str) or not isinstance(self.side, (tuple, list)):
            raise ValueError(f"ReflexConfig.side must be a list of keys, got {self.side!r}")
        if not self.side:
            raise ValueError("ReflexConfig.side must hold at least one key (e.g. 'goal'), got []")
        if len(set(self.side)) != len(self.side):
            raise ValueError(f"ReflexConfig.side: a key appears twice in {self.side!r}")
        for key in self.side:
            pair = key.split("/") if isinstance(key, str) else None
            if key != "goal" and (
                pair is None or len(pair) != 2 or not all(p in self.sectors for p in pair)
            ):
                raise ValueError(
                    f"ReflexConfig.side: bad key {key!r} (expected 'goal' or 'LEFT_SECTOR/"
                    f"RIGHT_SECTOR' of sectors {tuple(self.sectors)})"
                )


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


_RULE = re.compile(r"^\s*(?P<lhs>.+?)\s*->\s*(?:(?P<w>[0-9]*\.?[0-9]+)\s*\*\s*)?(?P<set>\w+)\s*$")


def parse_rule(
    text: str, sectors: tuple[str, ...], where: str = "rule"
) -> tuple[list[tuple[str, bool]], int, float]:
    """Read ``"F and not FL -> 0.5 * LEFT"`` into ([(literal, negated)], output index, weight);
    a literal is one of ``sectors`` or of :data:`SIDES`."""
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
        if not (len(words) == 1 or negated) or words[-1] not in (*sectors, *SIDES):
            raise ValueError(
                f"{where}: bad antecedent {part!r} in {text!r} "
                f"(expected a sector or 'not' sector; sectors: {sectors}, sides: {SIDES})"
            )
        literals.append((words[-1], negated))
    return literals, OUTPUTS.index(m["set"]), weight


def check_finite(sonar: np.ndarray, goal_angle: np.ndarray) -> None:
    """Raise the reflex's ValueError if a numpy batch holds a NaN or an inf: one reduction for
    the common case (a sum is finite only if every term is; a finite sum's overflow to inf is
    then told apart by the exact test)."""
    if not np.isfinite(sonar.sum() + goal_angle.sum()) and not (
        np.isfinite(sonar).all() and np.isfinite(goal_angle).all()
    ):
        raise ValueError("FuzzyReflex: sonar or goal_angle contains a non-finite value")


class FuzzyReflex(nn.Module):
    """``reflex(sonar (..., n_rays) in [0, 1], goal_angle (...)) -> crisp angle (...)``.

    Config compiled to buffers (S sectors, K rules, N rays; numbers kept in float64 and cast
    to the input's dtype, so float32 observations and float64 tests both compute exactly):
      ``sector_mask`` (S, N) bool, ``near_ab`` (S, 2), ``pos``/``neg`` (K, S + 2) bool literals
      (the S sectors, then ``SIDE_L``, ``SIDE_R``), ``rule_out`` (K, 3) rule weight on its
      output set, ``peaks`` (3,).

    These buffers (the ``state_dict``) are compiled once more into the few index tensors the
    hot path runs on: sector rays as one padded ``(S, M)`` index (a sector's distance is one
    gather and one ``amin``), rule antecedents as one padded ``(K, L)`` index into the literal
    vector ``(mu, 1 - mu)`` (a rule's strength is one gather and one ``amin``); if a rule uses
    the turning side, ``mu`` is extended by ``(SIDE_L, SIDE_R)`` from the signs of the side keys
    (``ReflexConfig.side``), weighted 2^(n-1), ..., 1 so the first non-zero one decides.
    Padding repeats an index of the same row, so a min over the padded row is the min over the
    set. Constants are cast to each input dtype/device once and cached; the cache is dropped by
    ``.to()`` / ``.float()`` etc. and ``load_state_dict``; after editing a buffer in place, call
    :meth:`recompile`. A batched call is a few dozen tensor ops; one float64 sample
    (:meth:`angle`, or the module on a 1-D float64 sonar) runs on Python floats. Both give the
    same numbers bit for bit as the uncompiled formulas (tests/knowledge/test_reflex_compiled.py).
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
        columns = (*names, *SIDES)
        pos = torch.zeros(n_k, len(columns), dtype=torch.bool)
        neg = torch.zeros(n_k, len(columns), dtype=torch.bool)
        rule_out = torch.zeros(n_k, 3, dtype=torch.float64)
        for k, text in enumerate(config.rules):
            literals, out, weight = parse_rule(text, names, where=f"ReflexConfig.rules[{k}]")
            for name, negated in literals:
                (neg if negated else pos)[k, columns.index(name)] = True
            rule_out[k, out] = weight
        self.register_buffer("sector_mask", mask)
        self.register_buffer(
            "near_ab", torch.tensor([config.near[n] for n in names], dtype=torch.float64)
        )
        self.register_buffer("pos", pos)
        self.register_buffer("neg", neg)
        self.register_buffer("rule_out", rule_out)
        self.register_buffer("peaks", torch.tensor(config.peaks, dtype=torch.float64))
        self._consts: dict[tuple[torch.dtype, torch.device], _Compiled] = {}
        self._plain: _Plain | None = None
        self._arrays: dict[str, Any] | None = None  # _Compiled as numpy, for _batch

    # --- the compiled rule base -------------------------------------------------------------

    def _compiled(self, like: torch.Tensor) -> _Compiled:
        """Index tensors and constants for inputs of ``like``'s dtype and device (cached)."""
        key = (like.dtype, like.device)
        consts = self._consts.get(key)
        if consts is None:
            consts = self._consts[key] = _Compiled.build(self, like.dtype, like.device)
        return consts

    def recompile(self) -> None:
        """Drop the compiled constants (rebuilt from the buffers on the next call)."""
        self._consts, self._plain, self._arrays = {}, None, None

    def _apply(self, fn, recurse=True):  # .to() / .double() / .cuda(): recompile lazily
        self._consts, self._plain, self._arrays = {}, None, None
        return super()._apply(fn, recurse)

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[override]
        self._consts, self._plain, self._arrays = {}, None, None
        super()._load_from_state_dict(*args, **kwargs)

    # --- the two behaviours -----------------------------------------------------------------

    def near(self, sonar: torch.Tensor) -> torch.Tensor:
        """NEAR membership of every sector ``(..., S)`` from normalised sonars ``(..., N)``."""
        return self._near(sonar, self._compiled(sonar))

    def _near(self, sonar: torch.Tensor, c: _Compiled) -> torch.Tensor:
        # Sector distance = min over its rays (one gather of the padded index, one amin).
        # Scaling after the min is exact: rounding x -> x * range is monotone.
        rays = sonar.index_select(-1, c.rays).unflatten(-1, c.rays_shape)
        sector = rays.amin(dim=-1) * self.config.sonar_range
        return torch.sub(c.b, sector).div_(c.b_minus_a).clamp_(0.0, 1.0)

    def avoid(self, sonar: torch.Tensor, goal_angle: torch.Tensor | float = 0.0) -> torch.Tensor:
        """Obstacle-avoidance activations ``(..., 3)``: min for AND, 1 - x for NOT, max per set.
        The goal angle only enters through the turning side (``ReflexConfig.side``)."""
        sonar, goal_angle = self._check(sonar, goal_angle)
        return self._avoid(sonar, _wrap(goal_angle), self._compiled(sonar))

    def side(self, sonar: torch.Tensor, goal_angle: torch.Tensor | float = 0.0) -> torch.Tensor:
        """The turning side ``(..., 2)``: (SIDE_L, SIDE_R), (1, 0) or (0, 1); (0.5, 0.5) only
        if every key of ``ReflexConfig.side`` ties (an exactly mirror-symmetric input)."""
        sonar, goal_angle = self._check(sonar, goal_angle)
        c = self._compiled(sonar)
        return self._side(self._near(sonar, c), _wrap(goal_angle), c)

    def _side(self, mu: torch.Tensor, wrapped: torch.Tensor, c: _Compiled) -> torch.Tensor:
        # key = NEAR(right) - NEAR(left) per pair (> 0: the left is freer; within the margin a
        # tie, 0), then the goal angle; signs weighted 2^(n-1) .. 1 sum to a number whose sign
        # is the first non-zero key's. The differences are one product with a +1 / -1 matrix
        # (exact: two non-zero terms each), the weighted signs small integers (exact in any
        # order); SIDE_L, SIDE_R = 0.5 + s * (0.5, -0.5), i.e. (1, 0), (0, 1) or (0.5, 0.5).
        diff = mu @ c.side_diff
        decisive = diff.abs() > self.config.side_margin
        keys = diff.sign_().mul_(decisive)
        s = (keys @ c.pair_weights).add_(wrapped.sign().mul_(c.goal_weight)).sign_()
        return torch.addcmul(c.side_half, s.unsqueeze(-1), c.side_step)

    def _avoid(self, sonar: torch.Tensor, wrapped: torch.Tensor, c: _Compiled) -> torch.Tensor:
        mu = self._near(sonar, c)
        if c.uses_side:  # literals SIDE_L, SIDE_R after the sectors
            mu = torch.cat((mu, self._side(mu, wrapped, c)), dim=-1)
        literals = torch.cat((mu, torch.rsub(mu, 1.0)), dim=-1)  # mu, then NOT mu
        if c.always_true:  # a rule without antecedent (only from hand-made buffers): 1.0
            literals = torch.cat((literals, torch.ones_like(mu[..., :1])), dim=-1)
        strength = literals.index_select(-1, c.literals).unflatten(-1, c.literals_shape)
        strength = strength.amin(dim=-1)  # (..., K)
        return (strength.unsqueeze(-1) * c.rule_out).amax(dim=-2)

    def follow(self, goal_angle: torch.Tensor) -> torch.Tensor:
        """Goal-following activations ``(..., 3)`` from the signed goal angle (left positive).

        The angle is wrapped to [-pi, pi] first, so 3*pi/2 reads as a right turn of pi/2.
        """
        return self._follow(_wrap(goal_angle))

    def _follow(self, wrapped: torch.Tensor) -> torch.Tensor:
        t = wrapped / self.config.goal_span
        return torch.stack((t, torch.rsub(t.abs(), 1.0), t.neg()), dim=-1).clamp_(0.0, 1.0)

    # --- fusion and defuzzification ---------------------------------------------------------

    def fused(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> torch.Tensor:
        """alpha_f = d_a * alpha_a + d_g * alpha_g (Eq. 5): ``(..., 3)`` (LEFT, FORWARD, RIGHT)."""
        sonar, goal_angle = self._check(sonar, goal_angle)
        return self._fused(sonar, goal_angle, self._compiled(sonar))

    def _fused(self, sonar: torch.Tensor, goal_angle: torch.Tensor, c: _Compiled) -> torch.Tensor:
        cfg = self.config
        wrapped = _wrap(goal_angle)
        follow = self._follow(wrapped).mul_(cfg.d_g)
        return self._avoid(sonar, wrapped, c).mul_(cfg.d_a).add_(follow)

    def forward(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> torch.Tensor:
        """Height defuzzification: sum(alpha_f * peak) / sum(alpha_f); 0 (ahead) if all silent.

        All activations are >= 0, so when they are all 0 the numerator is 0 too and the
        quotient by the clamped total is already the 0 of "all silent". The total is summed
        as (LEFT + RIGHT) + FORWARD, the same rounding for a mirrored input (exact symmetry)."""
        if (
            type(sonar) is torch.Tensor
            and sonar.dtype is torch.float64
            and sonar.dim() == 1
            and type(goal_angle) is torch.Tensor
            and goal_angle.dtype is torch.float64
            and goal_angle.dim() == 0
            and sonar.device.type == "cpu"
            and goal_angle.device.type == "cpu"
            and not (sonar.requires_grad or goal_angle.requires_grad)
        ):  # one float64 sample (the learner's call): plain floats, ~10x fewer dispatches
            return torch.tensor(self._single(sonar, goal_angle), dtype=torch.float64)
        if (
            type(sonar) is torch.Tensor
            and sonar.dtype is torch.float64
            and sonar.dim() == 2
            and sonar.shape[-1] == self.config.n_rays
            and type(goal_angle) is torch.Tensor
            and goal_angle.dtype is torch.float64
            and goal_angle.shape == sonar.shape[:1]
            and sonar.device.type == "cpu"
            and goal_angle.device.type == "cpu"
            and not (sonar.requires_grad or goal_angle.requires_grad)
        ):  # a float64 batch (the learner's call): numpy, ~5x fewer dispatches
            return self._batch(sonar, goal_angle)
        sonar, goal_angle = self._check(sonar, goal_angle)
        c = self._compiled(sonar)
        f = self._fused(sonar, goal_angle, c)
        total = (f[..., 0] + f[..., 2]).add_(f[..., 1]).clamp_min_(1e-12)
        return (f * c.peaks).sum(dim=-1).div_(total)

    def angle(self, sonar: torch.Tensor, goal_angle: float) -> float:
        """The crisp angle of ONE sample ``sonar (n_rays,)`` as a Python float, computed in
        float64: the same number as ``float(reflex(sonar.double(), tensor(goal_angle,
        float64)))``, without the module call, the casts and a grad/inference context (the
        learner's call, once per new neuron)."""
        goal = torch.tensor(float(goal_angle), dtype=torch.float64)
        if (
            type(sonar) is torch.Tensor
            and sonar.dim() == 1
            and sonar.is_floating_point()
            and sonar.device.type == "cpu"
        ):  # .tolist() of any float dtype gives the exact values .double() would
            return self._single(sonar, goal)
        with torch.no_grad():
            return float(self(sonar.double(), goal))

    def _batch(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> torch.Tensor:
        """:meth:`forward` of a float64 batch (B, n) in numpy on the tensors' memory: the
        operations of the tensor path in the same order, so the same numbers bit for bit
        (``tests/knowledge/test_reflex_compiled.py``); sin, cos and atan2 stay torch ops."""
        s = sonar.numpy()
        check_finite(s, goal_angle.numpy())
        return torch.from_numpy(self.wrapped_batch(s, _wrap(goal_angle).numpy()))

    def wrap(self, goal_angle: torch.Tensor) -> np.ndarray:
        """The goal angles of a float64 batch wrapped to [-pi, pi] as :meth:`forward` wraps
        them. torch's atan2 rounds the elements of a long batch's vectorised body differently
        from the others, so an angle's bits depend on its place in the batch: a caller that
        runs the reflex on some rows of a batch wraps the whole batch's angles here first."""
        return _wrap(goal_angle).numpy()

    def wrapped_batch(self, s: np.ndarray, wrapped: np.ndarray) -> np.ndarray:
        """:meth:`forward` of float64 sonars ``(B, n)`` (finite) at goal angles already
        wrapped (:meth:`wrap`), numpy in and out; each row's output depends on that row
        alone."""
        return self.from_memberships(self._memberships(s, self._numpy_arrays()), wrapped)

    def from_memberships(self, mu: np.ndarray, wrapped: np.ndarray) -> np.ndarray:
        """:meth:`wrapped_batch` from the sonars' NEAR memberships ``(B, S)``
        (:meth:`memberships`): the output reads the sonars only through them, so a caller
        that knows them (inputs that differ in one sector) skips the sonars' gather."""
        a = self._numpy_arrays()
        cfg = self.config
        batch = mu.shape[0]
        t = wrapped / cfg.goal_span
        # (LEFT, FORWARD, RIGHT) columns clipped to [0, 1] (min/max: np.clip's dispatch costs
        # about twice as much; the same numbers)
        follow = np.empty((batch, 3))
        follow[:, 0] = t
        follow[:, 1] = 1.0 - np.abs(t)
        follow[:, 2] = -t
        follow = np.minimum(np.maximum(follow, 0.0), 1.0) * cfg.d_g
        if a["uses_side"]:  # the turning side, as _side
            diff = mu @ a["side_diff"]
            keys = np.sign(diff) * (np.abs(diff) > cfg.side_margin)
            side = np.sign(keys @ a["pair_weights"] + np.sign(wrapped) * a["goal_weight"])
            mu = np.concatenate((mu, a["side_half"] + side[:, None] * a["side_step"]), axis=-1)
        literals = np.concatenate((mu, 1.0 - mu), axis=-1)
        if a["always_true"]:
            literals = np.concatenate((literals, np.ones_like(mu[:, :1])), axis=-1)
        # the batch axis innermost: the min and max reduce whole rows at a time, not 2 or 6
        # numbers at a time (about half the cost at the trial gradient's few hundred rows; the
        # same values: min and max are exact, the products the same pairs)
        rules = literals.T[a["literals"]].reshape(*a["literals_shape"], batch).min(axis=1)
        fired = np.maximum.reduce(a["rule_out_t"] * rules, axis=1)  # (3, B)
        # C order again for the sums below (a reduction's rounding follows the layout)
        f = np.ascontiguousarray(fired.T) * cfg.d_a + follow
        total = np.maximum((f[:, 0] + f[:, 2]) + f[:, 1], 1e-12)
        return (f * a["peaks"]).sum(axis=-1) / total

    def _numpy_arrays(self) -> dict[str, Any]:
        """The float64 compiled rule base as numpy arrays (:meth:`_batch`'s constants)."""
        a = self._arrays
        if a is None:
            c = self._compiled(torch.zeros((), dtype=torch.float64))._asdict()
            a = self._arrays = {
                k: v.numpy() if isinstance(v, torch.Tensor) else v for k, v in c.items()
            }
            a["rule_out_t"] = np.ascontiguousarray(a["rule_out"].T)[:, :, None]  # (3, rules, 1)
        return a

    def _memberships(self, s: np.ndarray, a: dict[str, Any]) -> np.ndarray:
        """NEAR of every sector ``(B, S)`` from float64 sonars ``(B, n)`` (:meth:`_batch`'s)."""
        sector = s[:, a["rays"]].reshape(len(s), *a["rays_shape"]).min(axis=-1)
        return np.minimum(np.maximum((a["b"] - sector * self.config.sonar_range)
                                     / a["b_minus_a"], 0.0), 1.0)  # fmt: skip

    def memberships(self, sonar: np.ndarray) -> np.ndarray:
        """NEAR of every sector ``(B, S)`` from float64 sonars ``(B, n)``, as :meth:`forward`
        computes it (numpy in, numpy out): a row whose memberships are another row's, at the
        same goal angle, has that row's output bit for bit."""
        return self._memberships(sonar, self._numpy_arrays())

    def _single(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> float:
        """The crisp angle of one float64 sample with Python floats (same numbers bit for bit as
        the tensor path, ``tests/knowledge/test_reflex_compiled.py``): the same operations in
        the same order, in IEEE double; sin and cos stay torch ops, as their results differ
        from libm's in the last bit for ~0.1% of angles (atan2's do not)."""
        p = self._plain
        if p is None:
            p = self._plain = _Plain.build(self)
        s = sonar.tolist()
        if len(s) != p.n_rays:
            raise ValueError(
                f"FuzzyReflex: sonar must have shape (..., {p.n_rays}), got {tuple(sonar.shape)}"
            )
        g = goal_angle.item()
        if not math.isfinite(sum(s) + g) and not all(map(math.isfinite, (*s, g))):
            raise ValueError("FuzzyReflex: sonar or goal_angle contains a non-finite value")
        # NEAR per sector, then 1 - NEAR: the literal vector (mu, 1 - mu[, 1])
        mu = []
        for rays, b, b_minus_a in p.sectors:
            v = (b - min([s[k] for k in rays]) * p.sonar_range) / b_minus_a
            mu.append(min(max(v, 0.0), 1.0))
        wrapped = math.atan2(torch.sin(goal_angle).item(), torch.cos(goal_angle).item())
        if p.uses_side:  # the turning side: the first key with a non-zero sign decides
            diffs = [mu[right] - mu[left] for left, right in p.side_pairs]
            keys = [d if abs(d) > p.side_margin else 0.0 for d in diffs] + [wrapped]
            key = next((k for k in (keys[i] for i in p.side_order) if k != 0.0), 0.0)
            side = 0.5 if key == 0.0 else (1.0 if key > 0.0 else 0.0)
            mu = [*mu, side, 1.0 - side]
        literals = mu + [1.0 - m for m in mu] + [1.0]
        strength = [min([literals[i] for i in rule]) for rule in p.rules]
        d_a, d_g = p.d_a, p.d_g
        avoid = [
            max([st * w for st, w in zip(strength, col, strict=True)]) * d_a for col in p.rule_out
        ]
        t = wrapped / p.goal_span
        follow = (min(max(t, 0.0), 1.0), min(max(1.0 - abs(t), 0.0), 1.0), min(max(-t, 0.0), 1.0))
        f0, f1, f2 = (a + fo * d_g for a, fo in zip(avoid, follow, strict=True))
        p0, p1, p2 = p.peaks
        return (f0 * p0 + f1 * p1 + f2 * p2) / max((f0 + f2) + f1, 1e-12)

    def _check(
        self, sonar: torch.Tensor, goal_angle: torch.Tensor | float
    ) -> tuple[torch.Tensor, torch.Tensor]:
        if not isinstance(sonar, torch.Tensor) or not sonar.is_floating_point():
            raise ValueError(f"FuzzyReflex: sonar must be a float tensor, got {type(sonar)}")
        if sonar.dim() < 1 or sonar.shape[-1] != self.config.n_rays:
            raise ValueError(
                f"FuzzyReflex: sonar must have shape (..., {self.config.n_rays}), "
                f"got {tuple(sonar.shape)}"
            )
        if (
            not isinstance(goal_angle, torch.Tensor)
            or goal_angle.dtype != sonar.dtype
            or goal_angle.device != sonar.device
        ):
            goal_angle = torch.as_tensor(goal_angle, dtype=sonar.dtype, device=sonar.device)
        batch = sonar.shape[:-1]
        if goal_angle.shape != batch:
            try:
                batch = torch.broadcast_shapes(batch, goal_angle.shape)
            except RuntimeError:
                raise ValueError(
                    f"FuzzyReflex: goal_angle shape {tuple(goal_angle.shape)} does not match the "
                    f"sonar batch shape {tuple(sonar.shape[:-1])}"
                ) from None
            sonar, goal_angle = sonar.expand(*batch, sonar.shape[-1]), goal_angle.expand(batch)
        # A NaN or inf anywhere makes the sum non-finite (one reduction, one sync); only then
        # (or if finite values overflow the sum) look element by element.
        if not math.isfinite(float(sonar.sum()) + float(goal_angle.sum())) and not (
            bool(torch.isfinite(sonar).all()) and bool(torch.isfinite(goal_angle).all())
        ):
            raise ValueError("FuzzyReflex: sonar or goal_angle contains a non-finite value")
        return sonar, goal_angle

    def extra_repr(self) -> str:
        c = self.config
        return f"sectors={list(self.sector_names)}, rules={len(c.rules)}, d_a={c.d_a}, d_g={c.d_g}"


def _wrap(angle: torch.Tensor) -> torch.Tensor:
    """An angle wrapped to [-pi, pi] (odd: a negated angle wraps to the negated result)."""
    return torch.atan2(torch.sin(angle), torch.cos(angle))


class _Compiled(NamedTuple):
    """The rule base of one :class:`FuzzyReflex` as index tensors, for one dtype and device."""

    rays: torch.Tensor
    """(S*M,) long: the rays of each sector, padded to M by repeating the sector's first ray."""
    rays_shape: tuple[int, int]
    b: torch.Tensor
    """(S,) the b of NEAR(a, b) per sector."""
    b_minus_a: torch.Tensor
    """(S,) b - a, computed in the input dtype (as the uncompiled formula did)."""
    literals: torch.Tensor
    """(K*L,) long into (mu_1..mu_S[, SIDE_L, SIDE_R], NOT of them[, 1]): each rule's
    literals, padded."""
    literals_shape: tuple[int, int]
    always_true: bool
    """Some rule has no literal (the last index, a constant 1)."""
    uses_side: bool
    """Some rule reads SIDE_L or SIDE_R (only then is the turning side computed)."""
    side_diff: torch.Tensor
    """(S, P): +1 at the right sector and -1 at the left one of each of the P side pairs
    (``mu @ side_diff`` = NEAR(right) - NEAR(left))."""
    pair_weights: torch.Tensor
    """(P,) weight of each pair key's sign: 2^(n-1) for the first key of ``ReflexConfig.side``
    down to 1 for the last."""
    goal_weight: float
    """The goal key's weight (0 if the goal is not a key)."""
    side_half: torch.Tensor
    """(2,) 0.5, 0.5."""
    side_step: torch.Tensor
    """(2,) 0.5, -0.5."""
    rule_out: torch.Tensor
    """(K, 3) the rule weight on its output set."""
    peaks: torch.Tensor

    @classmethod
    def build(cls, reflex: FuzzyReflex, dtype: torch.dtype, device: torch.device) -> _Compiled:
        mask = reflex.sector_mask.cpu()
        sectors = [torch.nonzero(row).flatten().tolist() for row in mask]
        width = max(len(r) for r in sectors)
        rays = [r + [r[0]] * (width - len(r)) for r in sectors]
        n_s = len(sectors)
        # A literal is mu where `pos`, else 1 - mu where `neg`, else absent (as torch.where did).
        pos, neg = reflex.pos.cpu(), reflex.neg.cpu()
        uses_side = bool((pos[:, n_s:] | neg[:, n_s:]).any())
        n_mu = pos.shape[1] if uses_side else n_s
        rules = [
            [s if pos[k, s] else n_mu + s for s in range(n_mu) if pos[k, s] or neg[k, s]]
            for k in range(pos.shape[0])
        ]
        always_true = any(not r for r in rules)
        rules = [r or [2 * n_mu] for r in rules]
        length = max(len(r) for r in rules)
        rules = [r + [r[0]] * (length - len(r)) for r in rules]
        ab = reflex.near_ab.to(dtype=dtype, device=device)
        b = ab[:, 1].contiguous()
        names, keys = reflex.sector_names, reflex.config.side
        pairs = [tuple(names.index(s) for s in key.split("/")) for key in keys if key != "goal"]
        order = _side_order(keys)
        weights = [0.0] * (len(pairs) + 1)
        for rank, i in enumerate(order):
            weights[i] = float(2 ** (len(order) - 1 - rank))
        side_diff = torch.zeros(n_s, len(pairs), dtype=dtype, device=device)
        for j, (left, right) in enumerate(pairs):
            side_diff[right, j] += 1.0
            side_diff[left, j] -= 1.0
        return cls(
            rays=torch.tensor(rays, dtype=torch.long, device=device).flatten(),
            rays_shape=(n_s, width),
            b=b,
            b_minus_a=(b - ab[:, 0]).contiguous(),
            literals=torch.tensor(rules, dtype=torch.long, device=device).flatten(),
            literals_shape=(len(rules), length),
            always_true=always_true,
            uses_side=uses_side,
            side_diff=side_diff,
            pair_weights=torch.tensor(weights[:-1], dtype=dtype, device=device),
            goal_weight=weights[-1],
            side_half=torch.tensor([0.5, 0.5], dtype=dtype, device=device),
            side_step=torch.tensor([0.5, -0.5], dtype=dtype, device=device),
            rule_out=reflex.rule_out.to(dtype=dtype, device=device),
            peaks=reflex.peaks.to(dtype=dtype, device=device),
        )


class _Plain(NamedTuple):
    """The rule base of one :class:`FuzzyReflex` as Python numbers (the single-sample path)."""

    n_rays: int
    sectors: list[tuple[tuple[int, ...], float, float]]
    """Per sector: its rays, b, and b - a (float64, as the tensor path computes them)."""
    uses_side: bool
    """Some rule reads SIDE_L or SIDE_R."""
    side_pairs: list[tuple[int, int]]
    """(left, right) sector indices of the side pairs (``ReflexConfig.side`` order)."""
    side_order: list[int]
    """The side keys in decision order, as indices into (pair keys..., goal)."""
    side_margin: float
    rules: list[tuple[int, ...]]
    """Per rule: indices of its literals in (mu_1..mu_S[, SIDE_L, SIDE_R], NOT of them, 1)."""
    rule_out: list[list[float]]
    """Per output set, the weight of every rule on it (0 for the other sets' rules)."""
    peaks: tuple[float, float, float]
    d_a: float
    d_g: float
    sonar_range: float
    goal_span: float

    @classmethod
    def build(cls, reflex: FuzzyReflex) -> _Plain:
        c = _Compiled.build(reflex, torch.float64, torch.device("cpu"))
        n_s, width = c.rays_shape
        rays = c.rays.view(n_s, width).tolist()
        n_k, length = c.literals_shape
        cfg = reflex.config
        names = reflex.sector_names
        pairs = [
            (names.index(a), names.index(b))
            for a, b in (key.split("/") for key in cfg.side if key != "goal")
        ]
        return cls(
            n_rays=reflex.sector_mask.shape[1],
            sectors=[
                (tuple(r), b, bma)
                for r, b, bma in zip(rays, c.b.tolist(), c.b_minus_a.tolist(), strict=True)
            ],
            uses_side=c.uses_side,
            side_pairs=pairs,
            side_order=_side_order(cfg.side),
            side_margin=float(cfg.side_margin),
            rules=[tuple(r) for r in c.literals.view(n_k, length).tolist()],
            rule_out=c.rule_out.T.tolist(),
            peaks=tuple(c.peaks.tolist()),
            d_a=float(cfg.d_a),
            d_g=float(cfg.d_g),
            sonar_range=float(cfg.sonar_range),
            goal_span=float(cfg.goal_span),
        )


def _side_order(keys: tuple[str, ...]) -> list[int]:
    """The side keys in decision order as indices into (pair keys in order..., goal)."""
    n_pairs = sum(key != "goal" for key in keys)
    order, pair = [], 0
    for key in keys:
        if key == "goal":
            order.append(n_pairs)
        else:
            order.append(pair)
            pair += 1
    return order
