"""The reflex's float64 CPU paths without torch's per-op dispatch: one sample on Python floats
(:func:`single`) and a batch on numpy (:func:`from_memberships`), the learner's calls.

Each runs the batched tensor path's operations in the same order in IEEE double, so all three
give the same numbers bit for bit (``tests/knowledge/test_reflex_compiled.py``); sin, cos and
atan2 of a batch stay torch ops (their results differ from libm's in the last bit).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch

from symrl.knowledge.reflex.compiled import Plain
from symrl.knowledge.reflex.config import ReflexConfig

__all__ = ["check_finite", "from_memberships", "memberships", "single"]


def check_finite(sonar: np.ndarray, goal_angle: np.ndarray) -> None:
    """Raise the reflex's ValueError if a numpy batch holds a NaN or an inf: one reduction for
    the common case (a sum is finite only if every term is; a finite sum's overflow to inf is
    then told apart by the exact test)."""
    if not np.isfinite(sonar.sum() + goal_angle.sum()) and not (
        np.isfinite(sonar).all() and np.isfinite(goal_angle).all()
    ):
        raise ValueError("FuzzyReflex: sonar or goal_angle contains a non-finite value")


def memberships(a: dict[str, Any], sonar_range: float, s: np.ndarray) -> np.ndarray:
    """NEAR of every sector ``(B, S)`` from float64 sonars ``(B, n)`` (``a``: :func:`arrays`)."""
    sector = s[:, a["rays"]].reshape(len(s), *a["rays_shape"]).min(axis=-1)
    return np.minimum(np.maximum((a["b"] - sector * sonar_range) / a["b_minus_a"], 0.0), 1.0)


def from_memberships(
    a: dict[str, Any], cfg: ReflexConfig, mu: np.ndarray, wrapped: np.ndarray
) -> np.ndarray:
    """The crisp angles ``(B,)`` from the sonars' NEAR memberships ``(B, S)`` at goal angles
    already wrapped to [-pi, pi] (``a``: :func:`arrays`)."""
    batch = mu.shape[0]
    t = wrapped / cfg.goal_span
    # (LEFT, FORWARD, RIGHT) columns clipped to [0, 1] (min/max: np.clip's dispatch costs
    # about twice as much; the same numbers)
    follow = np.empty((batch, 3))
    follow[:, 0] = t
    follow[:, 1] = 1.0 - np.abs(t)
    follow[:, 2] = -t
    follow = np.minimum(np.maximum(follow, 0.0), 1.0) * cfg.d_g
    if a["uses_side"]:  # the turning side, as FuzzyReflex._side
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


def single(p: Plain, sonar: torch.Tensor, goal_angle: torch.Tensor) -> float:
    """The crisp angle of one float64 sample with Python floats: the tensor path's operations
    in the same order, in IEEE double; sin and cos stay torch ops, as their results differ
    from libm's in the last bit for ~0.1% of angles (atan2's do not)."""
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
    avoid = [max([st * w for st, w in zip(strength, col, strict=True)]) * d_a for col in p.rule_out]
    t = wrapped / p.goal_span
    follow = (min(max(t, 0.0), 1.0), min(max(1.0 - abs(t), 0.0), 1.0), min(max(-t, 0.0), 1.0))
    f0, f1, f2 = (a + fo * d_g for a, fo in zip(avoid, follow, strict=True))
    p0, p1, p2 = p.peaks
    return (f0 * p0 + f1 * p1 + f2 * p2) / max((f0 + f2) + f1, 1e-12)
