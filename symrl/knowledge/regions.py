"""The symbolic region mapper of Hailu (2001) section 6.1, as a batched torch module.

The paper cuts the world "at its joints" with a few lines and first-match rules
(corridor, concave, room, door) that route every odometry pose to exactly one expert. The
rules are data in the map file; this module compiles them once into tensors so that a whole
batch of poses is classified with a handful of comparisons and no Python loop over poses.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.world.worldmap import RegionSpec, WorldMap, load_map

__all__ = ["RegionMapper"]


class RegionMapper(BufferViews):
    """Odometry poses ``(..., 2 or 3)`` -> region ids ``(...,)`` (long, in the order of ``names``).

    Each rule is a conjunction of strict comparisons ``axis > threshold`` / ``axis < threshold``
    (strict as in the paper: a pose exactly on a line satisfies neither side); the first rule
    whose conditions all hold names the region, and the map guarantees a final default rule.

    Compiled buffers (R rules, C = most conditions in a rule):
      ``axis`` (R, C) long, ``greater`` (R, C) bool, ``threshold`` (R, C) float64,
      ``used`` (R, C) bool (padding mask), ``rule_region`` (R,) long.
    Comparisons run in float64 so that results agree exactly with the scalar reference
    ``RegionSpec.region_of`` whatever the pose dtype.
    """

    axis: torch.Tensor
    greater: torch.Tensor
    threshold: torch.Tensor
    used: torch.Tensor
    rule_region: torch.Tensor
    select: torch.Tensor
    bound: torch.Tensor

    def __init__(self, spec: RegionSpec) -> None:
        super().__init__()
        if not isinstance(spec, RegionSpec):
            raise TypeError(f"RegionMapper: spec must be a RegionSpec, got {type(spec).__name__}")
        if not spec.rules or spec.rules[-1].conditions:
            raise ValueError(
                "RegionMapper: regions.rules must end with a default rule (no conditions), "
                f"got {spec.rules[-1] if spec.rules else spec.rules!r}"
            )
        self.names: tuple[str, ...] = tuple(spec.names)
        n_rules = len(spec.rules)
        n_conds = max(1, max(len(r.conditions) for r in spec.rules))
        axis = torch.zeros(n_rules, n_conds, dtype=torch.long)
        greater = torch.zeros(n_rules, n_conds, dtype=torch.bool)
        threshold = torch.zeros(n_rules, n_conds, dtype=torch.float64)
        used = torch.zeros(n_rules, n_conds, dtype=torch.bool)
        rule_region = torch.empty(n_rules, dtype=torch.long)
        for i, rule in enumerate(spec.rules):
            rule_region[i] = self.names.index(rule.region)
            for j, cond in enumerate(rule.conditions):
                axis[i, j] = cond.axis
                greater[i, j] = cond.greater
                threshold[i, j] = cond.threshold
                used[i, j] = True
        self.register_buffer("axis", axis)
        self.register_buffer("greater", greater)
        self.register_buffer("threshold", threshold)
        self.register_buffer("used", used)
        self.register_buffer("rule_region", rule_region)
        self.register_buffer("select", torch.empty(0), persistent=False)
        self.register_buffer("bound", torch.empty(0), persistent=False)
        self._derive()

    def _derive(self) -> None:
        """The buffers ``ids`` runs on, derived from the saved ones (not saved): a condition
        holds where sign * value > sign * threshold (sign +1 for ">", -1 for "<": the same test
        as value > / < threshold, since negation is exact). ``select`` (2, R*C) picks sign *
        the coordinate of every condition in one product (x * (+-1) + y * 0 is exact);
        ``bound`` (R*C,) is sign * threshold, -inf for padding (always true)."""
        sign = self.greater.to(torch.float64) * 2 - 1
        used = self.used.reshape(-1)
        select = torch.zeros(2, used.numel(), dtype=torch.float64, device=self.axis.device)
        flat = used.nonzero().flatten()
        select[self.axis.reshape(-1)[flat], flat] = sign.reshape(-1)[flat]
        self.select = select
        self.bound = (self.threshold * sign).masked_fill(~self.used, -torch.inf).reshape(-1)

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[override]
        super()._load_from_state_dict(*args, **kwargs)
        self._derive()

    @classmethod
    def from_map(cls, world: WorldMap | str | dict[str, Any] = "hailu2001") -> RegionMapper:
        """Build from a loaded ``WorldMap`` (or anything ``load_map`` accepts)."""
        if not isinstance(world, WorldMap):
            world = load_map(world)
        return cls(world.regions)

    def forward(self, poses: torch.Tensor) -> torch.Tensor:
        """Region id of every pose; only x and y are read (a heading column is ignored)."""
        if not isinstance(poses, torch.Tensor) or not poses.is_floating_point():
            raise ValueError(
                f"RegionMapper: poses must be a floating-point tensor, got "
                f"{getattr(poses, 'dtype', type(poses).__name__)}"
            )
        if poses.dim() < 1 or poses.shape[-1] not in (2, 3):
            raise ValueError(
                "RegionMapper: poses must have shape (..., 2) or (..., 3), "
                f"got {tuple(poses.shape)}"
            )
        xy = poses[..., :2].to(torch.float64)
        if not bool(torch.isfinite(xy).all()):
            raise ValueError("RegionMapper: poses contain a non-finite x or y")
        return self.ids(xy)

    def ids(self, xy: torch.Tensor) -> torch.Tensor:
        """:meth:`forward` without the input checks, for finite float64 ``xy`` (..., 2): the
        control loop's call (its poses come from the env, finite by construction)."""
        # numpy on the tensors' memory (a handful of poses: a fraction of the torch dispatches;
        # the product is exact, see _derive). (..., R, C): whether each condition holds
        # (padding always does)
        return torch.from_numpy(self.ids_np(xy.numpy()))

    def ids_np(self, xy: np.ndarray) -> np.ndarray:
        """:meth:`ids` on a numpy array (the control loop's poses are numpy already)."""
        a = self.arrays
        holds = xy @ a["select"] > a["bound"]
        holds = holds.reshape(*holds.shape[:-1], *a["axis"].shape)
        # First matching rule: argmax over booleans returns the first True.
        first = holds.all(axis=-1).argmax(axis=-1)
        return np.asarray(a["rule_region"][first])

    def extra_repr(self) -> str:
        return f"names={self.names}, rules={self.rule_region.numel()}"
