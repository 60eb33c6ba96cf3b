"""The one training loop: a collector's batches, an agent's learning, the trial table.

Every learner trains here (``symrl train`` and ``symrl study``'s paper learner, the SAC and PPO
recipes, a learner of your own: docs/how-to/add-a-learner.md):

    for batch in collector:                 one env step of the B robots (the agent's policy)
        td_error = agent.learn(batch)
        done = recorder.step(batch, td_error)        the trials' accumulators
        robots whose trial ended: recorder.finish, agent.end_trials -> table.add -> on_trial
        on_boundary(added); table.finished or stop() ends the loop

Two ways of counting trials, the table's job:

- :class:`RobotTrials` (the paper's learner): B independent robots, each its own table of
  ``trials`` rows; a robot that is done keeps driving (it cannot leave the batch) and its
  further trials are dropped; the loop ends when the last robot is done.
- :class:`SharedTrials` (the baselines): one learner over the B robots, one table of
  ``episodes`` rows numbered in the order the trials end (robots in index order within a
  step); the trials that end in the step the budget is reached beyond it are kept as
  ``pending`` (a resumed run with a larger budget takes them first).

The loop makes no random draw of its own, so a run's numbers are the agent's and the env's.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from contextlib import ExitStack
from typing import Any

import numpy as np
import torch

from symrl.agent import Agent
from symrl.recorder import TrialRecorder

__all__ = ["RobotTrials", "SharedTrials", "TrainingLoop"]

TD_COLUMN = "mean_abs_td_error"


class RobotTrials:
    """B robots' own tables of ``trials`` rows each (``rows``: the rows so far, resumed;
    ``closed``: the robots that are done already)."""

    def __init__(
        self,
        batch: int,
        trials: int,
        rows: list[list[dict[str, Any]]] | None = None,
        closed: Iterable[bool] | None = None,
    ) -> None:
        self.trials = trials
        self.rows = rows if rows is not None else [[] for _ in range(batch)]
        self.closed = list(closed) if closed is not None else [False] * batch
        self.total = trials * batch

    @property
    def count(self) -> int:
        """Rows in the tables."""
        return sum(len(r) for r in self.rows)

    @property
    def finished(self) -> bool:
        """Every robot is done."""
        return all(self.closed)

    def start(self) -> list[tuple[int, dict[str, Any]]]:
        """No rows to take before the first step."""
        return []

    def add(
        self,
        robots: list[int],
        records: list[dict[str, Any]],
        reached: np.ndarray,
        extras: list[dict[str, Any]],
    ) -> list[tuple[int, dict[str, Any]]]:
        """The ended trials of ``robots`` as rows of their robots' tables (those of robots that
        are done are dropped); the ``(robot, row)`` pairs added."""
        added = []
        for j, b in enumerate(robots):
            if self.closed[b]:
                continue  # this robot has done its trials: only driving on
            record = {"trial": len(self.rows[b]) + 1, **records[j]}
            record["reached_goal"] = bool(reached[j])
            record.update(extras[j])
            self.rows[b].append(record)
            added.append((b, record))
            self.closed[b] = len(self.rows[b]) == self.trials
        return added

    def postfix(self, added: list[tuple[int, dict[str, Any]]]) -> dict[str, Any] | None:
        """The progress bar's note: one robot's last trial (steps, total reinforcement)."""
        if len(self.rows) != 1 or not added:
            return None
        record = added[-1][1]
        return {"steps": record["steps"], "total": f"{record['total_reinforcement']:.2f}"}


class SharedTrials:
    """One table of ``episodes`` rows over all robots (``rows`` and ``pending``: resumed)."""

    def __init__(
        self,
        episodes: int,
        rows: list[dict[str, Any]] | None = None,
        pending: list[dict[str, Any]] | None = None,
    ) -> None:
        self.total = episodes
        self.rows = list(rows) if rows is not None else []
        self.pending = list(pending) if pending is not None else []

    @property
    def count(self) -> int:
        """Rows in the table."""
        return len(self.rows)

    @property
    def finished(self) -> bool:
        """The budget is reached."""
        return len(self.rows) >= self.total

    def start(self) -> list[tuple[int, dict[str, Any]]]:
        """The pending trials the budget now has room for, as rows (robot -1: not known)."""
        added = []
        while self.pending and len(self.rows) < self.total:
            record = self.pending.pop(0)
            self.rows.append(record)
            added.append((-1, record))
        return added

    def add(
        self,
        robots: list[int],
        records: list[dict[str, Any]],
        reached: np.ndarray,
        extras: list[dict[str, Any]],
    ) -> list[tuple[int, dict[str, Any]]]:
        """The ended trials, numbered in order; beyond the budget they are kept pending."""
        added = []
        for j, b in enumerate(robots):
            record = records[j]
            record.update(
                trial=len(self.rows) + len(self.pending) + 1, reached_goal=bool(reached[j])
            )
            record.update(extras[j])
            if len(self.rows) < self.total:
                self.rows.append(record)
                added.append((b, record))
            else:
                self.pending.append(record)
        return added

    def postfix(self, added: list[tuple[int, dict[str, Any]]]) -> dict[str, Any]:
        """The progress bar's note: the success rate of the last 20 trials."""
        last = self.rows[-20:]
        rate = np.mean([r["reached_goal"] for r in last]) if last else 0.0
        return {"success20": f"{rate:.2f}"}


class TrainingLoop:
    """Trains ``agent`` on ``collector``'s batches (a :class:`symrl.collector.StepCollector`
    acting with ``agent.policy``) into ``table`` (:class:`RobotTrials` or
    :class:`SharedTrials`), with ``recorder`` (the trials in progress; fresh or resumed).

    ``on_trial(robot, row)``: after every row added to the table (robot -1: a pending row
    taken on resume). ``on_boundary(added)``: after every step at which a trial ended, with
    the ``(robot, row)`` pairs it added (checkpoints). ``on_step()``: after every step (a bar
    of steps). ``stop()``: asked after every step; True ends the loop there (:attr:`stopped`).
    ``frames``: robot-steps before this loop (resumed); :attr:`frames` counts on. ``bar``: the
    progress bar's description and tqdm options.
    """

    def __init__(
        self,
        collector: Any,
        agent: Agent,
        table: RobotTrials | SharedTrials,
        recorder: TrialRecorder,
        *,
        on_trial: Callable[[int, dict[str, Any]], None] | None = None,
        on_boundary: Callable[[list[tuple[int, dict[str, Any]]]], None] | None = None,
        on_step: Callable[[], object] | None = None,
        stop: Callable[[], bool] | None = None,
        progress: bool = True,
        bar: dict[str, Any] | None = None,
        frames: int = 0,
    ) -> None:
        self.collector, self.agent, self.table, self.recorder = collector, agent, table, recorder
        self.on_trial, self.on_boundary, self.stop = on_trial, on_boundary, stop
        self.on_step = on_step
        self.progress, self.bar_options = progress, dict(bar or {})
        self.frames, self.stopped = frames, False
        self._bar: Any = None
        self._td_column = True

    def run(self) -> bool:
        """Step until the table is full or ``stop()``; True if stopped. Closes the collector
        (its env) and the progress bar, also on an error."""
        from tqdm.auto import tqdm

        collector, recorder, stop, on_step = self.collector, self.recorder, self.stop, self.on_step
        learn, batch = self.agent.learn, self.recorder.batch
        zeros = torch.zeros(batch)
        bar = tqdm(
            total=self.table.total,
            initial=self.table.count,
            unit="trial",
            disable=not self.progress,
            **self.bar_options,
        )
        self._bar = bar
        with ExitStack() as contexts:
            contexts.callback(collector.shutdown)
            contexts.callback(bar.close)
            self._take(self.table.start())
            if self.table.finished:
                return False
            for td in collector:
                td_error = learn(td)
                if td_error is None:
                    td_error, self._td_column = zeros, False
                self.frames += batch
                done = recorder.step(td, td_error)
                if on_step is not None:
                    on_step()
                if done.any():
                    added = self._end_trials(done)
                    if self.on_boundary is not None:
                        self.on_boundary(added)
                    if self.table.finished:
                        break
                if stop is not None and stop():
                    self.stopped = True
                    break
        return self.stopped

    def _end_trials(self, done: np.ndarray) -> list[tuple[int, dict[str, Any]]]:
        """The trials of the robots ``done`` into the table; the ``(robot, row)`` pairs added."""
        # the rows as numpy and Python ints: indexing and reading small tensors element by
        # element costs a torch dispatch each
        ended = np.flatnonzero(done)
        robots = ended.tolist()
        records = [self.recorder.finish(b) for b in robots]
        if not self._td_column:  # a learner without a TD error: no such column
            for record in records:
                del record[TD_COLUMN]
        reached = self.recorder.reached.numpy()[ended]
        extras = self.agent.end_trials(ended, records, reached)
        added = self.table.add(robots, records, reached, extras)
        self._take(added)
        postfix = self.table.postfix(added)
        if postfix is not None:
            self._bar.set_postfix(**postfix)
        return added

    def _take(self, added: list[tuple[int, dict[str, Any]]]) -> None:
        for b, record in added:
            self._bar.update(1)
            if self.on_trial is not None:
                self.on_trial(b, record)
