"""A saved controller checked against the one its config and map build, before it is loaded:
every entry present, of its dtype, finite, and within the range it can hold."""

from __future__ import annotations

import math
from typing import Any

import torch

_DERIVED = ("code_centres", "mapper.", "reflex.")
"""State entries rebuilt from the config and the map: a checkpoint's must equal them."""
_ANGLES = ("experts.actions", "experts.means", "experts.taken")
_MAX_ANGLE = 2 * math.pi
_AT_LEAST = {
    "progress.trials_done": 0,
    "options.critic.n": 0,
    "options.critic.trials": 0,
    "options.stage": 0,
    "progress.temperature": 0.0,
    "options.critic.epsilon": 0.0,
}


def _outside(values: torch.Tensor, low: int, high: int) -> int | None:
    """A value of the integer tensor ``values`` outside ``low..high`` (its largest when that is
    too high, else its smallest), or None when all are within."""
    if not values.numel():
        return None
    smallest, largest = int(values.min()), int(values.max())
    return largest if largest > high else smallest if smallest < low else None


def check_policy_state(state: dict[str, Any], fresh: dict[str, torch.Tensor]) -> str | None:
    """The first fault of a saved controller ``state`` against ``fresh``, the state dict of the
    controller its config and map build (None: it can be loaded): an entry missing, unknown, not
    a tensor or of another dtype; a non-finite number; an entry rebuilt from the config and the
    map that differs from it; a neuron count, option or region index out of range; an angle
    beyond 2 pi; a count, temperature or epsilon below 0 (epsilon above 1)."""
    missing = sorted(set(fresh) - set(state))
    if missing:
        return f"weights do not match its config and map ({missing[0]} is missing)"
    for key, value in state.items():
        if key not in fresh:
            return f"weights do not match its config and map ({key} is unknown to them)"
        if not isinstance(value, torch.Tensor):
            return f"policy entry {key} is not a tensor ({type(value).__name__})"
        want = fresh[key]
        if value.dtype != want.dtype:
            return (
                f"weights do not match its config and map ({key} has dtype {value.dtype}, "
                f"not {want.dtype})"
            )
        # best_total is -inf until a trial reaches the goal; nothing else may be non-finite
        ok = torch.isfinite(value) | ((key == "progress.best_total") & (value == -torch.inf))
        if value.is_floating_point() and not bool(ok.all()):
            return f"non-finite values in {key}"
        if key.startswith(_DERIVED) and not (
            value.shape == want.shape and bool(torch.equal(value, want))
        ):
            return f"weights do not match its config and map ({key} differs from theirs)"
    for key, low in _AT_LEAST.items():
        if key in state and state[key].numel() and float(state[key].min()) < low:
            return f"policy entry {key} holds {float(state[key].min()):g}, below {low:g}"
    epsilon = state.get("options.critic.epsilon")
    if epsilon is not None and epsilon.numel() and float(epsilon.max()) > 1.0:
        return f"policy entry options.critic.epsilon holds {float(epsilon.max()):g}, above 1"
    for key in _ANGLES:
        if key in state and state[key].numel():
            big = float(state[key].abs().max())
            if big > _MAX_ANGLE:
                return f"policy entry {key} holds an angle of {big:g} rad, beyond 2 pi"
    if "experts.count" in state and "experts.used" in state:
        count, used = state["experts.count"], state["experts.used"]
        capacity = used.shape[2] if used.dim() >= 3 else 0
        bad = _outside(count, 0, capacity)
        if bad is not None:
            return (
                f"policy entry experts.count holds {bad} neurons, outside 0..{capacity} "
                "(the stored neurons)"
            )
    # an option index (the critic's last axis) and a region index (its second last), -1: none
    for key, axis, what in (("options.choice", -1, ""), ("options.visit", -2, "region ")):
        if key in state and "options.critic.q" in state:
            top = state["options.critic.q"].shape[axis] - 1
            bad = _outside(state[key], -1, top)
            if bad is not None:
                return f"policy entry {key} holds {what}{bad}, outside -1..{top}"
    return None
