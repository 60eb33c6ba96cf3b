"""The one training loop and the agent protocol: any agent trains through it with the same
trial table; the paper's learner through it is ``train_batch``; the two ways of counting
trials (each robot its own table, one table shared by the robots)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs.utils import ExplorationType

from symrl.agent import Agent
from symrl.collector import StepCollector
from symrl.learner.config import load_config
from symrl.loop import RobotTrials, SharedTrials, TrainingLoop
from symrl.recorder import TrialRecorder
from symrl.train import make_env, train_batch

BASE = [
    "trial",
    "steps",
    "total_reinforcement",
    "collisions",
    "shielded",
    "path_length",
    "path",
    "ghosts",
    "reached_goal",
]


class _Straight(TensorDictModuleBase):
    """Every robot turns by ``angle`` each step (the shield never acts)."""

    def __init__(self, angle: float) -> None:
        super().__init__()
        self.angle = angle
        self.in_keys, self.out_keys = ["sonar"], ["action", "shielded"]

    def forward(self, td: TensorDictBase) -> TensorDictBase:
        b = td.batch_size[0]
        td.set("action", torch.full((b, 1), self.angle))
        td.set("shielded", torch.zeros(b, dtype=torch.bool))
        return td


class ConstantAgent:
    """A constant action, no learning: the smallest agent. Counts what the loop asks of it."""

    def __init__(self, angle: float = 0.0, td_error: bool = False) -> None:
        self.policy = _Straight(angle)
        self.td_error = td_error
        self.learned = 0
        self.ended: list[list[int]] = []

    def learn(self, td: TensorDictBase) -> torch.Tensor | None:
        self.learned += 1
        return torch.zeros(td.batch_size[0]) if self.td_error else None

    def end_trials(
        self, rows: np.ndarray, records: list[dict[str, Any]], reached: np.ndarray
    ) -> list[dict[str, Any]]:
        self.ended.append(rows.tolist())
        return [{"constant": self.policy.angle} for _ in rows]

    def state_dict(self) -> dict[str, Any]:
        return {"learned": self.learned}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.learned = state["learned"]


@pytest.fixture(scope="module")
def config():
    # short trials: a robot driving straight ahead runs into the budget
    return load_config("paper", ["env.max_actions=15"])


def _loop(config, agent, table, seeds, **kwargs) -> TrainingLoop:
    env = make_env(config, seeds)
    collector = StepCollector(env, agent.policy, exploration_type=ExplorationType.RANDOM)
    return TrainingLoop(
        collector, agent, table, TrialRecorder(len(seeds)), progress=False, **kwargs
    )


def test_a_constant_agent_is_an_agent():
    assert isinstance(ConstantAgent(), Agent)


def test_a_tiny_agent_trains_through_the_loop_with_the_trial_table_columns(config):
    agent = ConstantAgent(angle=0.3)
    seen: list[tuple[int, int]] = []
    loop = _loop(
        config,
        agent,
        RobotTrials(2, 3),
        [0, 1],
        on_trial=lambda b, row: seen.append((b, row["trial"])),
    )
    assert loop.run() is False
    rows = loop.table.rows
    assert [[r["trial"] for r in robot] for robot in rows] == [[1, 2, 3], [1, 2, 3]]
    # the base columns, the agent's own, and no TD error column (learn returned None)
    assert list(rows[0][0]) == BASE + ["constant"]
    assert all(r["constant"] == 0.3 and 1 <= r["steps"] <= 15 for robot in rows for r in robot)
    assert sorted(seen) == [(b, t) for b in (0, 1) for t in (1, 2, 3)]
    assert agent.learned * 2 == loop.frames == sum(r["steps"] for robot in rows for r in robot)
    assert all(e == sorted(e) for e in agent.ended)  # robots in index order


def test_a_td_error_makes_its_column(config):
    loop = _loop(config, ConstantAgent(td_error=True), RobotTrials(1, 1), [0])
    loop.run()
    (row,) = loop.table.rows[0]
    assert row["mean_abs_td_error"] == 0.0 and list(row)[:6] == BASE[:5] + ["mean_abs_td_error"]


def test_a_robot_that_is_done_drives_on_and_its_trials_are_dropped(config):
    # the robots' trials differ in length (their noise): the first one done waits
    agent = ConstantAgent(angle=0.2)
    config = load_config("paper", ["env.max_actions=40"])
    loop = _loop(config, agent, RobotTrials(3, 2), [0, 1, 2])
    loop.run()
    rows = loop.table.rows
    assert [len(r) for r in rows] == [2, 2, 2]
    ended = sum(len(e) for e in agent.ended)
    assert ended >= 6 and loop.frames == 3 * agent.learned
    last = max(sum(r["steps"] for r in robot) for robot in rows)
    assert agent.learned == last  # the loop ends when the last robot is done


def test_a_shared_table_numbers_trials_as_they_end_and_keeps_the_rest_pending(config):
    agent = ConstantAgent()
    loop = _loop(config, agent, SharedTrials(4), [0, 1, 2])
    loop.run()
    table = loop.table
    # straight ahead, every robot's trial ends at the same step: 3 trials a step
    assert [r["trial"] for r in table.rows] == [1, 2, 3, 4]
    assert [r["trial"] for r in table.pending] == [5, 6]
    assert agent.ended == [[0, 1, 2], [0, 1, 2]] and loop.frames == 3 * agent.learned
    # a resumed table with a larger budget takes its pending trials first
    more = SharedTrials(5, table.rows, table.pending)
    assert [r["trial"] for _, r in more.start()] == [5] and more.finished
    assert [r["trial"] for r in more.pending] == [6]


def test_stop_ends_the_loop_between_two_steps(config):
    calls = iter(range(100))
    agent = ConstantAgent()
    loop = _loop(config, agent, RobotTrials(2, 5), [0, 1], stop=lambda: next(calls) >= 6)
    assert loop.run() is True and loop.stopped
    assert agent.learned == 7 and loop.frames == 14


def test_on_step_is_called_once_a_step(config):
    steps: list[int] = []
    agent = ConstantAgent()
    loop = _loop(config, agent, RobotTrials(2, 1), [0, 1], on_step=lambda: steps.append(1))
    loop.run()
    # straight ahead into the 15-action budget: one trial of 15 steps per robot
    assert len(steps) == agent.learned == 15 and loop.frames == 30


def test_greedy_trials_of_a_learned_controller_are_driven_by_the_loop(config):
    from symrl.assembly import assemble_greedy
    from symrl.evaluate import GreedyDriver, rollout
    from symrl.train import train

    result = train(load_config("paper", ["run.trials=2", "run.seed=3"]), progress=False)
    policy = result.policy
    assert isinstance(GreedyDriver(policy), Agent)
    copies, env = assemble_greedy(
        result.config, policy.knowledge, [policy.state_dict()] * 2, [4, 4], result.world
    )
    first = rollout(copies, env)
    copies, env = assemble_greedy(
        result.config, policy.knowledge, [policy.state_dict()] * 2, [4, 4], result.world
    )
    again = rollout(copies, env)
    # one record per robot, without a trial number; the same seed and controller: the same trial
    assert len(first) == 2 and "trial" not in first[0]
    assert first[0]["path"] == again[0]["path"] and first[0]["steps"] == again[0]["steps"]


def test_the_paper_learner_through_the_loop_is_train_batch(config):
    from symrl.assembly import assemble
    from symrl.teseo import TeseoAgent

    config = load_config("paper", ["run.trials=3"])
    seeds = [5, 6]
    expected = [r.trials for r in train_batch(config, seeds, progress=False)]
    run = assemble(config, seeds)
    collector, agent = run.collector, TeseoAgent(run.policy, run.update)
    loop = TrainingLoop(collector, agent, RobotTrials(2, 3), TrialRecorder(2), progress=False)
    with torch.inference_mode():
        loop.run()
    assert loop.table.rows == expected
    assert "mean_abs_td_error" in expected[0][0] and "neurons" in expected[0][0]


def test_a_baseline_is_an_agent_of_the_loop():
    from symrl.learner.config import load_config
    from symrl.studies.baseline import make_env as baseline_env
    from symrl.studies.baseline_agent import BaselineAgent
    from symrl.studies.priors import PriorAction, priors_of
    from symrl.studies.sac import SACAgent

    sizes = [
        "baseline.sac.hidden=8",
        "baseline.sac.batch_size=8",
        "baseline.sac.learning_starts=10",
    ]
    config = load_config("sac", ["baseline.residual=true", *sizes])
    priors = priors_of(config)
    env = baseline_env(config, [3])
    n_obs = env.observation_spec["observation"].shape[-1]
    sac = SACAgent(config.baseline.sac, n_obs, 1)
    agent = BaselineAgent(sac, PriorAction(priors, config))
    assert isinstance(agent, Agent)
    loop = TrainingLoop(
        StepCollector(env, agent.policy), agent, SharedTrials(2), TrialRecorder(1), progress=False
    )
    loop.run()
    assert [r["trial"] for r in loop.table.rows] == [1, 2]
    assert "mean_abs_td_error" not in loop.table.rows[0]
    assert sac.frames == loop.frames and sac.updates == loop.frames - 10 + 1
    assert agent.state_dict()["frames"] == loop.frames


def test_the_reflex_alone_is_an_agent_that_learns_nothing():
    from symrl.learner.config import load_config
    from symrl.studies.baseline import make_env as baseline_env
    from symrl.studies.baseline import robot_seeds
    from symrl.studies.baseline_agent import ReflexAgent
    from symrl.studies.priors import PriorAction, Priors

    config = load_config("sac", ["baseline.residual=true"])
    priors = Priors(residual=True)
    agent = ReflexAgent(PriorAction(priors, config))
    assert isinstance(agent, Agent)
    env = baseline_env(config, robot_seeds(100, 2))
    loop = TrainingLoop(
        StepCollector(env, agent.policy), agent, SharedTrials(6), TrialRecorder(2), progress=False
    )
    loop.run()
    rows = loop.table.rows
    # the shielded reflex finds the goal of the paper's map from its start, in about 42 actions
    assert [r["trial"] for r in rows] == [1, 2, 3, 4, 5, 6]
    assert all(r["reached_goal"] for r in rows) and np.mean([r["steps"] for r in rows]) < 60
    assert list(rows[0]) == [c for c in BASE if c != "trial"][:-1] + ["trial", "reached_goal"]
    assert agent.state_dict() == {}
    with pytest.raises(ValueError, match="priors.residual=False"):
        ReflexAgent(PriorAction(Priors(), config))
