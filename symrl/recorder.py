"""The trial table's accumulators: per-robot steps, reinforcement, collisions, path and ghosts
of the trial in progress, read from each batch of transitions (:class:`TrialRecorder`)."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from symrl.tensordicts import read

__all__ = ["TrialRecorder"]

_RECORDER_ARRAYS = ("steps", "total", "collisions", "shielded", "td_error", "_start", "_first")


class TrialRecorder:
    """Per-robot accumulators of the current trial, read from each batch of transitions."""

    def __init__(self, batch: int) -> None:
        self.batch = batch
        self.steps = np.zeros(batch, dtype=np.int64)
        self.total = np.zeros(batch)
        self.collisions = np.zeros(batch, dtype=np.int64)
        self.shielded = np.zeros(batch, dtype=np.int64)
        self.td_error = np.zeros(batch)
        self._poses: list[np.ndarray] = []  # (B, 2) true positions after each step
        self._winners: list[np.ndarray] = []  # (B,) expert/winner id acting at each step
        self._offset = 0  # global step of _poses[0]
        self._start = np.zeros(batch, dtype=np.int64)  # global step each trial started at
        self._first = np.zeros((batch, 2))  # the trial's start position

    def step(self, td, td_error: torch.Tensor) -> np.ndarray:
        """Record one transition of every robot; return the mask of robots whose trial ended."""
        nxt = read(td, "next")
        fresh = self.steps == 0
        if fresh.any():
            self._first[fresh] = read(td, "true_pose")[:, :2].numpy()[fresh]
        self.steps += 1
        # numpy on the tensors' memory: a numpy call costs a fraction of a torch op's dispatch
        self.total += read(nxt, "reward").numpy().reshape(-1)  # float32 widened exactly
        self.collisions += read(nxt, "collision").numpy().reshape(-1)
        self.shielded += read(td, "shielded").numpy()
        self.td_error += np.abs(td_error.numpy())
        self.reached = read(nxt, "reached_goal").reshape(-1)
        self._poses.append(read(nxt, "true_pose").numpy()[:, :2].copy())
        expert, winner = read(td, "expert", None), read(td, "winner", None)
        if expert is None:  # a controller without neurons (the baselines): no ghosts
            self._winners.append(np.zeros(self.batch, dtype=np.int64))
        else:
            self._winners.append(expert.numpy() * 1_000_003 + winner.numpy())
        return read(nxt, "done").numpy().reshape(-1).copy()

    def finish(self, b: int) -> dict[str, Any]:
        """Robot ``b``'s trial record (its path and ghosts included); resets its accumulators."""
        lo, hi = self._start[b] - self._offset, len(self._poses)
        # the steps' arrays joined in one call, then robot b's rows (not a Python loop over the
        # steps)
        path = np.concatenate(
            (self._first[b : b + 1], np.concatenate(self._poses[lo:hi])[b :: self.batch])
        )
        ids = np.concatenate(self._winners[lo:hi])[b :: self.batch]
        change = np.flatnonzero(np.concatenate(([True], ids[1:] != ids[:-1])))
        rounded = path.round(4)
        record: dict[str, Any] = {
            "steps": int(self.steps[b]),
            "total_reinforcement": float(self.total[b]),
            "collisions": int(self.collisions[b]),
            "shielded": int(self.shielded[b]),
            "mean_abs_td_error": float(self.td_error[b] / max(self.steps[b], 1)),
            # np.linalg.norm(axis=1)'s own formula, without its argument handling
            "path_length": float(np.sqrt(np.add.reduce(np.square(path[1:] - path[:-1]), 1)).sum()),
            "path": rounded.tolist(),
            "ghosts": rounded[change].tolist(),  # where the acting neuron changed
        }
        self.steps[b] = 0
        self.total[b] = self.collisions[b] = self.shielded[b] = self.td_error[b] = 0
        self._start[b] = self._offset + hi
        self._trim()
        return record

    def state(self) -> dict[str, Any]:
        """The accumulators of the trials in progress, as tensors (a run snapshot between two
        steps, the baselines' resume)."""
        arrays = {k: getattr(self, k) for k in _RECORDER_ARRAYS}
        reached = getattr(self, "reached", None)
        return {
            **{k: torch.from_numpy(v.copy()) for k, v in arrays.items()},
            "poses": torch.from_numpy(np.array(self._poses).reshape(-1, self.batch, 2)),
            "winners": torch.from_numpy(
                np.array(self._winners, dtype=np.int64).reshape(-1, self.batch)
            ),
            "offset": int(self._offset),
            "reached": None if reached is None else reached.clone(),
        }

    def load_state(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`state`."""
        for k in _RECORDER_ARRAYS:
            setattr(self, k, state[k].numpy().copy())
        self._poses = list(state["poses"].numpy().copy())
        self._winners = list(state["winners"].numpy().copy())
        self._offset = int(state["offset"])
        if state["reached"] is not None:
            self.reached = state["reached"].clone()

    def _trim(self) -> None:
        drop = int(self._start.min()) - self._offset
        if drop > 512:  # forget steps no running trial needs
            del self._poses[:drop], self._winners[:drop]
            self._offset += drop
