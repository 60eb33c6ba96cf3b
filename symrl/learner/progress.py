"""What B controllers count across trials besides their experts and options.

The policy reads the exploration temperature when it acts; the update
(:class:`symrl.learner.update.TeseoUpdate`) closes trials through this module's methods. It is one
module handed to both (the policy holds it, so a controller's state dict carries it), and only
its own methods write its buffers.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews

__all__ = ["TrialProgress"]


class TrialProgress(BufferViews):
    """Buffers, one row per controller: ``temperature`` (B,) T of Eq. 6, cooled after every
    trial; ``best_total`` (B,) the best total of a goal-reaching trial so far (the bar of action
    replacement; -inf before the first); ``trials_done`` (B,) trials closed."""

    temperature: torch.Tensor
    best_total: torch.Tensor
    trials_done: torch.Tensor

    def __init__(self, batch: int, temperature0: float) -> None:
        super().__init__()
        self.register_buffer("temperature", torch.full((batch,), temperature0, dtype=torch.float64))
        self.register_buffer("best_total", torch.full((batch,), -math.inf, dtype=torch.float64))
        self.register_buffer("trials_done", torch.zeros(batch, dtype=torch.long))

    def improve(self, rows: np.ndarray, totals: np.ndarray, reached: np.ndarray) -> np.ndarray:
        """Robots ``rows`` finished trials of ``totals`` (float64), ``reached`` the goal or not:
        the mask of those that beat their best success, whose best becomes that total."""
        best = self.arrays["best_total"]
        improved = reached & (totals > best[rows])
        best[rows] = np.where(improved, totals, best[rows])
        return improved

    def cool(self, rows: np.ndarray, cooling: float, minimum: float) -> None:
        """T <- max(minimum, cooling * T) for robots ``rows``."""
        temperature = self.arrays["temperature"]
        temperature[rows] = np.maximum(cooling * temperature[rows], minimum)

    def temperatures(self, rows: np.ndarray) -> np.ndarray:
        """The temperatures of robots ``rows`` now (a copy)."""
        return self.arrays["temperature"][rows]

    def best_totals(self, rows: np.ndarray) -> np.ndarray:
        """The best successful totals of robots ``rows`` (a copy; -inf before the first)."""
        return self.arrays["best_total"][rows]

    def count(self, rows: np.ndarray) -> None:
        """One trial more done by robots ``rows``."""
        self.arrays["trials_done"][rows] += 1
