"""The returns of the trials in progress, one row per robot: what the option critics learn from.

The update adds every reward to its robot's return so far and marks where each option was
chosen; at a trial's end it takes the returns-to-go from those choices and the row starts over.
Only this module's methods write its buffers (saved as the update's state: a run resumed in
the middle of a trial goes on with them).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews

__all__ = ["TrialReturns"]


class TrialReturns(BufferViews):
    """``trial_return`` (B,) the return so far; ``entry_return`` (B, R) the return at each
    region's first entry; with ``choices`` options per region, ``choice_return`` (B, R, K) the
    return at each option's last choice in the trial (its first with ``keep_first``; NaN where
    none was made)."""

    trial_return: torch.Tensor
    entry_return: torch.Tensor
    choice_return: torch.Tensor

    def __init__(
        self, batch: int, regions: int, choices: int | None = None, keep_first: bool = False
    ) -> None:
        super().__init__()
        self.keep_first = keep_first
        self.register_buffer("trial_return", torch.zeros(batch, dtype=torch.float64))
        self.register_buffer("entry_return", torch.zeros(batch, regions, dtype=torch.float64))
        self.choices = choices is not None
        if choices is not None:
            self.register_buffer(
                "choice_return",
                torch.full((batch, regions, choices), math.nan, dtype=torch.float64),
            )

    def enter(self, rows: np.ndarray, region: np.ndarray, option: np.ndarray | None) -> None:
        """Robots ``rows`` chose an option (``option[rows]``, with choices) in region
        ``region[rows]``: the return so far is where its return-to-go starts."""
        a = self.arrays
        so_far = a["trial_return"][rows]
        a["entry_return"][rows, region[rows]] = so_far
        if self.choices and option is not None:
            at = (rows, region[rows], option[rows])
            if self.keep_first:  # an option chosen again keeps the return at its first choice
                so_far = np.where(np.isnan(a["choice_return"][at]), so_far, a["choice_return"][at])
            a["choice_return"][at] = so_far

    def add(self, reward: np.ndarray) -> None:
        """Every robot's reward (B,) float64 of this step."""
        self.arrays["trial_return"][:] += reward

    def so_far(self) -> np.ndarray:
        """The returns so far (B,), read only."""
        view = self.arrays["trial_return"].view()
        view.flags.writeable = False
        return view

    def close_choices(
        self, rows: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The choices of robots ``rows``' trials as (robot, region, option, return-to-go), and
        those rows' choices forgotten."""
        a = self.arrays
        chosen = a["choice_return"][rows]  # (k, R, K)
        i, r, o = np.nonzero(~np.isnan(chosen))
        to_go = a["trial_return"][rows[i]] - chosen[i, r, o]
        a["choice_return"][rows] = math.nan
        a["entry_return"][rows] = 0.0
        return rows[i], r, o, to_go

    def close_entries(self, rows: np.ndarray) -> np.ndarray:
        """The returns-to-go (k, R) from each region's first entry in robots ``rows``' trials,
        and those entries forgotten."""
        a = self.arrays
        returns = a["trial_return"][rows, None] - a["entry_return"][rows]
        a["entry_return"][rows] = 0.0
        return returns

    def close(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a new trial."""
        self.arrays["trial_return"][rows] = 0.0
