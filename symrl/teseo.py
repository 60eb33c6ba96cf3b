"""The paper's learner as an agent of the training loop (:class:`TeseoAgent`): the mixture of
experts policy acts, the TESEO update learns from every transition and ends the robots'
trials, and the trial table gets the learner's columns (neurons per expert, temperature,
replaced, improved, crossings, option choices)."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase

from symrl.tensordicts import read

__all__ = ["TeseoAgent"]


class TeseoAgent:
    """``policy`` (a :class:`symrl.learner.policy.MixtureOfExpertsPolicy`) and ``update`` (its
    :class:`symrl.learner.update.TeseoUpdate`) as an :class:`symrl.agent.Agent`."""

    def __init__(self, policy: Any, update: Any) -> None:
        self.policy, self.update = policy, update

    def learn(self, td: TensorDictBase) -> torch.Tensor:
        """The TESEO update of every robot's transition; its absolute TD error per robot."""
        return read(self.update(td), "td_error")

    def end_trials(
        self, rows: np.ndarray, records: list[dict[str, Any]], reached: np.ndarray
    ) -> list[dict[str, Any]]:
        """The update's end of the robots' trials; their learner columns."""
        index = torch.from_numpy(rows)
        # float32 as torch.tensor of the floats makes it, for a fraction of its cost
        totals = torch.from_numpy(
            np.array([r["total_reinforcement"] for r in records], dtype=np.float32)
        )
        out = self.update.end_trial(index, totals, torch.from_numpy(reached))
        return _trial_extras(self.policy, index, out)

    def state_dict(self) -> dict[str, Any]:
        """The policy's and the update's state dicts."""
        return {"policy": self.policy.state_dict(), "update": self.update.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state_dict`."""
        self.policy.load_state_dict(state["policy"])
        self.update.load_state_dict(state["update"])


def _trial_extras(policy, rows: torch.Tensor, out: dict[str, torch.Tensor]) -> list[dict[str, Any]]:
    """The learner columns of the trial records of robots ``rows`` (``out``: what
    ``update.end_trial`` returned for them, with the temperature each trial explored with).
    Tensors are read once per call, not per robot."""
    # numpy on the buffers' memory: a small tensor's indexing costs a torch dispatch
    index = rows.numpy()
    counts = policy.experts.count.numpy()[index].tolist()
    replaced, improved = out["replaced"].tolist(), out["improved"].tolist()
    temperature = out["temperature"].tolist()
    choices = policy.options.choice.numpy()[index].tolist() if policy.options is not None else None
    extras = []
    for j in range(len(counts)):
        extra: dict[str, Any] = {"neurons": sum(counts[j])}
        extra.update(
            {f"neurons_{n}": c for n, c in zip(policy.expert_names, counts[j], strict=True)}
        )
        extra.update(temperature=temperature[j], replaced=replaced[j], improved=improved[j])
        crossings = policy.options.crossings if policy.options is not None else None
        if crossings is not None:
            extra.update(crossings.summary(int(index[j]), hidden_too=policy.options.bridges))
        goal_scans = policy.options.goal_scans if policy.options is not None else None
        if goal_scans is not None:
            extra.update(goal_scans.summary(int(index[j])))
        wall_follow = policy.options.wall_follow if policy.options is not None else None
        if wall_follow is not None:
            extra.update(wall_follow.summary(int(index[j])))
        extra.update(policy.perception.summary(int(index[j])))
        if choices is not None:
            labels = policy.options.labels
            for r, name in enumerate(policy.region_names):
                if choices[j][r] >= 0:
                    extra[f"option_{name}"] = labels[r][choices[j][r]]
        extras.append(extra)
    return extras
