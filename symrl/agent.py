"""What the training loop needs of a learner: the agent protocol.

:func:`symrl.loop.train_loop` trains anything that has these four parts, whatever it learns
with (the paper's learner, :class:`symrl.teseo.TeseoAgent`; SAC and PPO,
:class:`symrl.studies.baseline_agent.BaselineAgent`; the reflex alone,
:class:`symrl.studies.baseline_agent.ReflexAgent`):

    policy                       a TorchRL policy: reads a batch [B], writes ``action`` and
                                 ``shielded`` (whether the IR shield overrode the action)
    learn(batch)                 learns from the batch [B] of transitions (root + ``next``);
                                 the per-robot TD error (B,), or None (no such column)
    end_trials(rows, records, reached)
                                 the robots ``rows``' trials ended: their extra columns
    state_dict() / load_state_dict(state)
                                 everything it has learnt, to go on from (resume)

The loop calls ``policy`` (through the collector) before the env step of each batch, then
``learn`` with its transitions, then ``end_trials`` for the robots whose trial ended at that
step, in index order. A ``learn`` that returns None leaves the ``mean_abs_td_error`` column out
of the trial table.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
import torch
from tensordict import TensorDictBase

__all__ = ["Agent", "LearnsNothing", "NoExtraColumns", "no_extras"]


@runtime_checkable
class Agent(Protocol):
    """A learner the training loop trains (see the module docstring)."""

    policy: Any
    """A TorchRL policy (a ``TensorDictModule``): reads the batch [B], writes ``action`` (B, 1)
    and ``shielded`` (B,)."""

    def learn(self, td: TensorDictBase) -> torch.Tensor | None:
        """Learn from one batch [B] of transitions; the per-robot TD error (B,) or None."""
        ...

    def end_trials(
        self, rows: np.ndarray, records: list[dict[str, Any]], reached: np.ndarray
    ) -> list[dict[str, Any]]:
        """The trials of robots ``rows`` (int64, ascending) ended with ``records`` (the trial
        table's base columns) and ``reached`` (bool, one per row): one dict of extra columns
        per row (empty dicts for none)."""
        ...

    def state_dict(self) -> dict[str, Any]:
        """Everything the agent has learnt and holds, as tensors and plain values."""
        ...

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state_dict` (a fresh agent of the same settings)."""
        ...


def no_extras(rows: np.ndarray) -> list[dict[str, Any]]:
    """No extra columns for the trials of ``rows`` (an agent's ``end_trials`` without any)."""
    return [{} for _ in range(len(rows))]


class NoExtraColumns:
    """``end_trials`` of an agent that adds nothing to the trial table's base columns."""

    def end_trials(
        self, rows: np.ndarray, records: list[dict[str, Any]], reached: np.ndarray
    ) -> list[dict[str, Any]]:
        """Nothing to add to the base columns."""
        return no_extras(rows)


class LearnsNothing(NoExtraColumns):
    """The parts of an agent that learns nothing (the reflex alone, greedy trials): no TD error
    column, no extra columns, no state. Subclasses set ``policy``."""

    policy: Any

    def learn(self, td: TensorDictBase) -> torch.Tensor | None:
        """Nothing to learn."""
        return None

    def state_dict(self) -> dict[str, Any]:
        """Nothing learnt."""
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Nothing to load."""
