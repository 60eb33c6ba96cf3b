"""The reflex's rule base compiled once for its hot paths: the index tensors the batched torch
path gathers with (:class:`Compiled`, per dtype and device), and the same compilation converted
to numpy arrays (:func:`arrays`) and to Python numbers (:class:`Plain`) for the float64 paths.

There is one compilation; the numpy and Python forms only change the number type, so the three
paths read the same indices and the same constants. Padding repeats an index of the same row,
so a min over a padded row is the min over the set.
"""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

import numpy as np
import torch

from symrl.knowledge.reflex.config import ReflexConfig

__all__ = ["Compiled", "Plain", "RuleBuffers", "arrays"]


class RuleBuffers(Protocol):
    """What the compiler reads: the rule base as the module's buffers (``FuzzyReflex``)."""

    sector_mask: torch.Tensor
    near_ab: torch.Tensor
    pos: torch.Tensor
    neg: torch.Tensor
    rule_out: torch.Tensor
    peaks: torch.Tensor
    sector_names: tuple[str, ...]
    config: ReflexConfig


class Compiled(NamedTuple):
    """The rule base of one reflex as index tensors, for one dtype and device."""

    n_rays: int
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
    side_pairs: tuple[tuple[int, int], ...]
    """(left, right) sector indices of the side pairs (``ReflexConfig.side`` order)."""
    side_order: tuple[int, ...]
    """The side keys in decision order, as indices into (pair keys..., goal)."""
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
    def build(cls, reflex: RuleBuffers, dtype: torch.dtype, device: torch.device) -> Compiled:
        mask = reflex.sector_mask.cpu()
        sectors = [torch.nonzero(row).flatten().tolist() for row in mask]
        width = max(len(r) for r in sectors)
        rays = [r + [r[0]] * (width - len(r)) for r in sectors]
        n_s = len(sectors)
        rules, uses_side, always_true = _rule_literals(reflex.pos.cpu(), reflex.neg.cpu(), n_s)
        length = max(len(r) for r in rules)
        rules = [r + [r[0]] * (length - len(r)) for r in rules]
        ab = reflex.near_ab.to(dtype=dtype, device=device)
        b = ab[:, 1].contiguous()
        names, keys = reflex.sector_names, reflex.config.side
        pairs = tuple(
            (names.index(left), names.index(right))
            for left, right in (key.split("/") for key in keys if key != "goal")
        )
        order = _side_order(keys)
        weights = [0.0] * (len(pairs) + 1)
        for rank, i in enumerate(order):
            weights[i] = float(2 ** (len(order) - 1 - rank))
        side_diff = torch.zeros(n_s, len(pairs), dtype=dtype, device=device)
        for j, (left, right) in enumerate(pairs):
            side_diff[right, j] += 1.0
            side_diff[left, j] -= 1.0
        return cls(
            n_rays=mask.shape[1],
            rays=torch.tensor(rays, dtype=torch.long, device=device).flatten(),
            rays_shape=(n_s, width),
            b=b,
            b_minus_a=(b - ab[:, 0]).contiguous(),
            literals=torch.tensor(rules, dtype=torch.long, device=device).flatten(),
            literals_shape=(len(rules), length),
            always_true=always_true,
            uses_side=uses_side,
            side_pairs=pairs,
            side_order=tuple(order),
            side_diff=side_diff,
            pair_weights=torch.tensor(weights[:-1], dtype=dtype, device=device),
            goal_weight=weights[-1],
            side_half=torch.tensor([0.5, 0.5], dtype=dtype, device=device),
            side_step=torch.tensor([0.5, -0.5], dtype=dtype, device=device),
            rule_out=reflex.rule_out.to(dtype=dtype, device=device),
            peaks=reflex.peaks.to(dtype=dtype, device=device),
        )


def _rule_literals(
    pos: torch.Tensor, neg: torch.Tensor, n_s: int
) -> tuple[list[list[int]], bool, bool]:
    """Each rule's literal indices (unpadded), whether any rule reads the turning side, and
    whether any rule has no literal (it then reads the constant 1 after the NOTs)."""
    # A literal is mu where `pos`, else 1 - mu where `neg`, else absent (as torch.where did).
    uses_side = bool((pos[:, n_s:] | neg[:, n_s:]).any())
    n_mu = pos.shape[1] if uses_side else n_s
    rules = [
        [s if pos[k, s] else n_mu + s for s in range(n_mu) if pos[k, s] or neg[k, s]]
        for k in range(pos.shape[0])
    ]
    always_true = any(not r for r in rules)
    return [r or [2 * n_mu] for r in rules], uses_side, always_true


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


def arrays(c: Compiled) -> dict[str, Any]:
    """A float64 CPU :class:`Compiled` as numpy arrays (the numpy batch path's constants), with
    ``rule_out_t`` (3, K, 1), the rule weights laid out for a max over rules per output set."""
    a = {k: v.numpy() if isinstance(v, torch.Tensor) else v for k, v in c._asdict().items()}
    a["rule_out_t"] = np.ascontiguousarray(a["rule_out"].T)[:, :, None]
    return a


class Plain(NamedTuple):
    """The rule base of one reflex as Python numbers (the single-sample path)."""

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
    def build(cls, c: Compiled, cfg: ReflexConfig) -> Plain:
        """From the float64 CPU :class:`Compiled` and the config's scalars."""
        n_s, width = c.rays_shape
        rays = c.rays.view(n_s, width).tolist()
        n_k, length = c.literals_shape
        p0, p1, p2 = c.peaks.tolist()
        return cls(
            n_rays=c.n_rays,
            sectors=[
                (tuple(r), b, bma)
                for r, b, bma in zip(rays, c.b.tolist(), c.b_minus_a.tolist(), strict=True)
            ],
            uses_side=c.uses_side,
            side_pairs=list(c.side_pairs),
            side_order=list(c.side_order),
            side_margin=float(cfg.side_margin),
            rules=[tuple(r) for r in c.literals.view(n_k, length).tolist()],
            rule_out=c.rule_out.T.tolist(),
            peaks=(p0, p1, p2),
            d_a=float(cfg.d_a),
            d_g=float(cfg.d_g),
            sonar_range=float(cfg.sonar_range),
            goal_span=float(cfg.goal_span),
        )
