"""A learner of your own, trained by symrl's one training loop (docs/how-to/add-a-learner.md).

The shielded fuzzy reflex steers each robot toward the goal; on top of it every robot learns a
constant steering correction by (1+1) hill climbing over trials: a trial's total reinforcement
that beats the robot's best keeps the correction it drove with, and the next trial tries the
best correction plus a little Gaussian noise. The class implements the four parts of
``symrl.agent.Agent``; everything else (env, collector, trial table, progress bar) is symrl's.

    python examples/hill_climbing_reflex.py --trials 20 --seed 0 --robots 2
"""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase

from symrl.collector import StepCollector
from symrl.learner.config import RunConfig, load_config
from symrl.loop import RobotTrials, TrainingLoop
from symrl.recorder import TrialRecorder
from symrl.studies.baseline import make_env, robot_seeds
from symrl.studies.priors import PriorAction, Priors

PRIORS = Priors(residual=True)
"""The reflex's action plus a correction of at most +-45 deg (``control`` in [-1, 1])."""


class _Steer(TensorDictModuleBase):
    """Writes each robot's current correction as ``control``, then the shielded ``action``."""

    def __init__(self, agent: HillClimbingReflex, config: RunConfig) -> None:
        super().__init__()
        self.agent = agent
        self.to_action = PriorAction(PRIORS, config)
        self.in_keys = ["reflex_action", "ir"]
        self.out_keys = ["control", "action", "shielded"]

    def forward(self, td: TensorDictBase) -> TensorDictBase:
        td.set("control", self.agent.correction.clone())
        return self.to_action(td)


class HillClimbingReflex:
    """The reflex plus a per-robot correction tuned by hill climbing: an ``Agent``."""

    def __init__(self, config: RunConfig, robots: int, seed: int = 0, step: float = 0.2) -> None:
        self.step = step
        self.correction = torch.zeros(robots, 1)  # what each robot drives with now
        self.best = torch.zeros(robots, 1)
        self.best_total = torch.full((robots,), -math.inf)
        self.generator = torch.Generator().manual_seed(seed)
        self.policy = _Steer(self, config)

    def learn(self, td: TensorDictBase) -> torch.Tensor | None:
        """Nothing to learn within a trial; no TD error (no such column in the table)."""
        return None

    def end_trials(
        self, rows: np.ndarray, records: list[dict[str, Any]], reached: np.ndarray
    ) -> list[dict[str, Any]]:
        """Keep the correction of a better trial; try the best one plus noise next."""
        extras = []
        for j, b in enumerate(rows.tolist()):
            total = records[j]["total_reinforcement"]
            if total > self.best_total[b]:
                self.best_total[b], self.best[b] = total, self.correction[b]
            noise = self.step * torch.randn(1, generator=self.generator)
            self.correction[b] = (self.best[b] + noise).clamp(-1.0, 1.0)
            extras.append({"correction": round(float(self.best[b]), 4)})
        return extras

    def state_dict(self) -> dict[str, Any]:
        return {
            "correction": self.correction.clone(),
            "best": self.best.clone(),
            "best_total": self.best_total.clone(),
            "generator": self.generator.get_state(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.correction = state["correction"].clone()
        self.best = state["best"].clone()
        self.best_total = state["best_total"].clone()
        self.generator.set_state(state["generator"])


def train(
    trials: int = 20, seed: int = 0, robots: int = 1, progress: bool = True
) -> list[list[dict[str, Any]]]:
    """``robots`` robots (world seeds as the baselines') learn for ``trials`` trials
    each; their trial tables."""
    # the world of the baseline recipes (env, reflex, shield), seed and budget
    config = load_config("sac", [f"run.seed={seed}", f"run.trials={trials}"])
    env = make_env(config, robot_seeds(seed, robots), priors=PRIORS)
    agent = HillClimbingReflex(config, robots, seed)
    loop = TrainingLoop(
        StepCollector(env, agent.policy),
        agent,
        RobotTrials(robots, trials),
        TrialRecorder(robots),
        progress=progress,
        bar={"desc": "hill-climbing reflex"},
    )
    loop.run()
    return loop.table.rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--robots", type=int, default=1)
    args = parser.parse_args()
    for b, rows in enumerate(train(args.trials, args.seed, args.robots)):
        for r in rows:
            print(
                f"robot {b} trial {r['trial']:3d}: {r['steps']:3d} actions, total "
                f"{r['total_reinforcement']:8.2f}, goal {r['reached_goal']}, "
                f"best correction {r['correction']:+.3f}"
            )


if __name__ == "__main__":
    main()
