"""The fuzzy reflex as a batched torch module: the rule base held as buffers, the two
behaviours (obstacle avoidance, goal following), their fusion (Eq. 5) and height
defuzzification, over any leading batch shape; float64 CPU calls go to :mod:`.fast`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch
from torch import nn

from symrl.knowledge.reflex import fast
from symrl.knowledge.reflex.compiled import Compiled, Plain, arrays
from symrl.knowledge.reflex.config import ReflexConfig
from symrl.knowledge.reflex.rules import SIDES, parse_rule

__all__ = ["FuzzyReflex"]


class FuzzyReflex(nn.Module):
    """``reflex(sonar (..., n_rays) in [0, 1], goal_angle (...)) -> crisp angle (...)``.

    Config compiled to buffers (S sectors, K rules, N rays; numbers kept in float64 and cast
    to the input's dtype, so float32 observations and float64 tests both compute exactly):
      ``sector_mask`` (S, N) bool, ``near_ab`` (S, 2), ``pos``/``neg`` (K, S + 2) bool literals
      (the S sectors, then ``SIDE_L``, ``SIDE_R``), ``rule_out`` (K, 3) rule weight on its
      output set, ``peaks`` (3,).

    These buffers (the ``state_dict``) are compiled once more (:mod:`.compiled`) into the few
    index tensors the hot path runs on: sector rays as one padded ``(S, M)`` index (a sector's
    distance is one gather and one ``amin``), rule antecedents as one padded ``(K, L)`` index
    into the literal vector ``(mu, 1 - mu)`` (a rule's strength is one gather and one
    ``amin``); if a rule uses the turning side, ``mu`` is extended by ``(SIDE_L, SIDE_R)``
    from the signs of the side keys (``ReflexConfig.side``), weighted 2^(n-1), ..., 1 so the
    first non-zero one decides.
    Constants are cast to each input dtype/device once and cached; the cache is dropped by
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
        self._consts: dict[tuple[torch.dtype, torch.device], Compiled] = {}
        self._plain: Plain | None = None
        self._arrays: dict[str, Any] | None = None  # Compiled as numpy, for _batch

    # --- the compiled rule base -------------------------------------------------------------

    def _compiled(self, like: torch.Tensor) -> Compiled:
        """Index tensors and constants for inputs of ``like``'s dtype and device (cached)."""
        key = (like.dtype, like.device)
        consts = self._consts.get(key)
        if consts is None:
            consts = self._consts[key] = Compiled.build(self, like.dtype, like.device)
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

    def _near(self, sonar: torch.Tensor, c: Compiled) -> torch.Tensor:
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

    def _side(self, mu: torch.Tensor, wrapped: torch.Tensor, c: Compiled) -> torch.Tensor:
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

    def _avoid(self, sonar: torch.Tensor, wrapped: torch.Tensor, c: Compiled) -> torch.Tensor:
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

    def _fused(self, sonar: torch.Tensor, goal_angle: torch.Tensor, c: Compiled) -> torch.Tensor:
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
        fast.check_finite(s, goal_angle.numpy())
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
        return self.from_memberships(self.memberships(s), wrapped)

    def from_memberships(self, mu: np.ndarray, wrapped: np.ndarray) -> np.ndarray:
        """:meth:`wrapped_batch` from the sonars' NEAR memberships ``(B, S)``
        (:meth:`memberships`): the output reads the sonars only through them, so a caller
        that knows them (inputs that differ in one sector) skips the sonars' gather."""
        return fast.from_memberships(self._numpy_arrays(), self.config, mu, wrapped)

    def _numpy_arrays(self) -> dict[str, Any]:
        """The float64 compiled rule base as numpy arrays (:meth:`_batch`'s constants)."""
        a = self._arrays
        if a is None:
            a = self._arrays = arrays(self._compiled(torch.zeros((), dtype=torch.float64)))
        return a

    def memberships(self, sonar: np.ndarray) -> np.ndarray:
        """NEAR of every sector ``(B, S)`` from float64 sonars ``(B, n)``, as :meth:`forward`
        computes it (numpy in, numpy out): a row whose memberships are another row's, at the
        same goal angle, has that row's output bit for bit."""
        return fast.memberships(self._numpy_arrays(), self.config.sonar_range, sonar)

    def _single(self, sonar: torch.Tensor, goal_angle: torch.Tensor) -> float:
        """The crisp angle of one float64 sample with Python floats (:func:`fast.single`)."""
        p = self._plain
        if p is None:
            c = self._compiled(torch.zeros((), dtype=torch.float64))
            p = self._plain = Plain.build(c, self.config)
        return fast.single(p, sonar, goal_angle)

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
