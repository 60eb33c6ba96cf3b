"""Aim corrections: the experts turn the bearing the reflex steers at, not its output action.

Why (docs/LEARNING.md, "Aim corrections"): the reflex is a feedback controller. A correction
added to its output action is steered back within a step or two, so it hardly changes the
trial's return and REINFORCE sees noise. Added to the *bearing* the reflex steers at (the
goal's or the option's sub-goal's angle), the same number turns where the reflex goes, and the
reflex's own feedback keeps it there over the following steps.

With ``aim.enabled`` the winning neuron's correction p + xi (p its action, xi its exploration
draw, the same Gaussian unit as for output corrections) is an offset in radians, clipped to
``aim.limit``, added to the target bearing; the robot's action is the reflex's response to the
turned bearing. With ``aim.hold`` the exploration draw is held while the same neuron wins, so an
explored offset acts over the neuron's whole stay, as the reflex would carry it. The TD critic
and the REINFORCE step of the update are unchanged (they read ``xi`` as before), or, with
``aim.learn: trial``, the means learn once per trial from the option critic's averaged
return-to-go (:func:`trial_step`) instead of from one-step TD errors.
"""

from __future__ import annotations

import math

import torch

from symrl.learner.experts import ExpertBank

__all__ = ["aimed_bearing", "HeldDraws", "trial_step"]

_PI = math.pi
_KEY_STRIDE = 1 << 32  # key = expert * stride + neuron: independent of the bank's capacity


def aimed_bearing(target: torch.Tensor, offset: torch.Tensor, limit: float) -> torch.Tensor:
    """The bearing ``target`` (left positive, radians) turned by ``offset`` clipped to
    [-limit, limit], wrapped to [-pi, pi] only where it left it (a zero offset returns
    ``target``'s bits). Odd: aimed(-t, -o) = -aimed(t, o) away from the wrap at +-pi."""
    turned = target + offset.clamp(-limit, limit)
    wrapped = torch.remainder(turned + _PI, 2 * _PI) - _PI
    return torch.where(turned.abs() > _PI, wrapped, turned)


class HeldDraws:
    """One standard normal per robot, held while the same neuron of the same expert wins.

    :meth:`hold` takes each robot's winner key and a fresh draw (drawn every step, so the random
    streams do not depend on what is held) and returns the held draw: the stored one where the
    key is the previous step's, else the fresh one, which is stored. :meth:`forget` drops the
    held draws of robots starting a new trial.
    """

    def __init__(self, batch: int) -> None:
        self.key = torch.full((batch,), -1, dtype=torch.long)
        self.z = torch.zeros(batch, dtype=torch.float64)

    @staticmethod
    def keys(expert: torch.Tensor, neuron: torch.Tensor) -> torch.Tensor:
        """The key of neuron ``neuron`` of expert ``expert`` (both (B,), neuron >= 0)."""
        return expert.long() * _KEY_STRIDE + neuron.long()

    def hold(self, key: torch.Tensor, fresh: torch.Tensor) -> torch.Tensor:
        same = key == self.key
        z = torch.where(same, self.z, fresh)
        self.key = key.clone()
        self.z = z.clone()
        return z

    def forget(self, rows: torch.Tensor) -> None:
        self.key[rows] = -1


@torch.no_grad()
def trial_step(
    bank: ExpertBank,
    rows: torch.Tensor,
    returns: torch.Tensor,
    baseline: torch.Tensor,
    rate: float,
    clip: float,
    limit: float,
) -> None:
    """End-of-trial REINFORCE step of the offsets' means for controllers ``rows``: every neuron
    of expert e used in the trial moves mu += rate * clip(G_e - q_e, +-clip) * (xi - mu), with
    ``returns`` G (k, E) the return-to-go from region e's first entry and ``baseline`` q (k, E)
    the averaged return-to-go of the option chosen there (0 advantage where a region was not
    entered). xi - mu is the neuron's last exploration in the trial (``taken - p - mu``); the
    means stay within +-``limit`` (beyond it the offset is clipped and a mean only drifts)."""
    used = bank.used[rows]
    means = bank.means[rows]
    explored = bank.taken[rows] - bank.actions[rows] - means
    advantage = (returns - baseline).clamp(-clip, clip).unsqueeze(-1)
    stepped = (means + rate * advantage * explored).clamp(-limit, limit)
    bank.means[rows] = torch.where(used, stepped, means)
