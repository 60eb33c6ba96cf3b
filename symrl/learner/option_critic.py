"""The critic of the sub-goal options of B controllers: what they learn across trials.

The options (:class:`symrl.learner.options.SubgoalOptions`, part of the policy) read it to choose
a region's option; the update (:class:`symrl.learner.update.TeseoUpdate`) steps it at the end of a
trial. It is one module handed to both, and only its own methods write its buffers.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews

__all__ = ["OptionCritic"]


class OptionCritic(BufferViews):
    """Buffers: ``q`` (B, R, K) mean (or best) return-to-go of each region's options, ``n``
    (B, R, K) trials that chose each, ``epsilon`` (B,) the actor's exploration rate, ``trials``
    (B,) trials learned from, with ``stalls`` ``stalled`` (B, R, K): the options that needed
    another to finish their region (they are not chosen again), and with ``shortest``
    ``shortest`` (B,): the fewest actions of a trial that reached the goal (inf: none yet).
    ``credit`` ("first" or "last"): which choice of an option chosen twice in a region and trial
    its return-to-go is taken from (the update reads it)."""

    q: torch.Tensor
    n: torch.Tensor
    epsilon: torch.Tensor
    trials: torch.Tensor

    def __init__(
        self,
        batch: int,
        regions: int,
        options: int,
        epsilon: float,
        epsilon_decay: float,
        critic: str = "mean",
        credit: str = "last",
        stalls: bool = False,
        shortest: bool = False,
    ) -> None:
        super().__init__()
        self.epsilon_decay = float(epsilon_decay)
        self.critic = critic
        self.credit = credit
        self.register_buffer("q", torch.zeros(batch, regions, options, dtype=torch.float64))
        self.register_buffer("n", torch.zeros(batch, regions, options, dtype=torch.long))
        self.register_buffer("epsilon", torch.full((batch,), float(epsilon), dtype=torch.float64))
        self.register_buffer("trials", torch.zeros(batch, dtype=torch.long))
        if stalls:
            self.register_buffer("stalled", torch.zeros(batch, regions, options, dtype=torch.bool))
        if shortest:
            self.register_buffer("shortest", torch.full((batch,), math.inf, dtype=torch.float64))

    @property
    def stalls(self) -> bool:
        """Whether the critic remembers stalled options."""
        return "stalled" in self._buffers

    @property
    def tracks_shortest(self) -> bool:
        """Whether the critic remembers each robot's shortest trial to the goal."""
        return "shortest" in self._buffers

    def shortest_trial(self, b: int) -> float:
        """Robot ``b``'s fewest actions in a trial that reached the goal (inf: none yet)."""
        return float(self.arrays["shortest"][b])

    def finish(self, rows: np.ndarray, steps: np.ndarray, reached: np.ndarray) -> None:
        """Robots ``rows``' trials took ``steps`` (k,) actions and ``reached`` (k,) the goal or
        not: the shortest trials so far follow."""
        shortest = self.arrays["shortest"]
        won = rows[reached]
        shortest[won] = np.minimum(shortest[won], steps[reached])

    def stall(self, b: int, region: int, option: int) -> None:
        """Controller ``b``'s ``option`` needed another to finish ``region``."""
        self.arrays["stalled"][b, region, option] = True

    def learn(self, rows: np.ndarray, choice: np.ndarray, returns: np.ndarray) -> None:
        """Critic step at the end of the trials of controllers ``rows``: ``choice`` (k, R) the
        option each region was visited with (-1: not entered), ``returns`` (k, R) the
        return-to-go from each region's first entry; then epsilon decays (an option that timed
        out was stalled when it did, :meth:`stall`)."""
        # numpy on the buffers' memory: a few advanced indexes of a handful of rows
        entered = choice >= 0
        i, r = np.nonzero(entered)  # row-major, as a mask of the broadcast indices
        self.learn_choices(rows[i], r, choice[entered], returns[entered])
        self.end_trials(rows)

    def learn_choices(self, b: np.ndarray, r: np.ndarray, k: np.ndarray, ret: np.ndarray) -> None:
        """Critic step for the choices ``(b, r, k)`` (controller, region, option; each triple
        once) with their returns-to-go ``ret`` from the moment each was chosen."""
        a = self.arrays
        n, q = a["n"], a["q"]
        n[b, r, k] += 1  # (b, r) pairs are distinct: one option per region and trial
        if self.critic == "best":
            first = n[b, r, k] == 1
            q[b, r, k] = np.where(first, ret, np.maximum(q[b, r, k], ret))
        else:
            q[b, r, k] += (ret - q[b, r, k]) / n[b, r, k]

    def end_trials(self, rows: np.ndarray) -> None:
        """The trials of controllers ``rows`` are over: epsilon decays, the count grows."""
        a = self.arrays
        a["epsilon"][rows] *= self.epsilon_decay
        a["trials"][rows] += 1
