"""The training loop's collector: batches, partial resets, state round trip, TorchRL protocol."""

from __future__ import annotations

import copy

import pytest
import torch
from tensordict import TensorDict
from torchrl.collectors import BaseCollector
from torchrl.envs.utils import ExplorationType

from symrl.assembly import build_policy
from symrl.collector import StepCollector
from symrl.learner.config import load_config
from symrl.train import make_env

SEEDS = [3, 4, 5]


def _collector(total_frames: int = -1, max_actions: int = 200) -> StepCollector:
    config = load_config("paper", [f"env.max_actions={max_actions}"])
    env = make_env(config, SEEDS)
    policy = build_policy(config, env.world, SEEDS)
    env = env.append_transform(policy.perception_transform())
    return StepCollector(
        env, policy, total_frames=total_frames, exploration_type=ExplorationType.RANDOM
    )


def _actions(collector: StepCollector, batches: int) -> list[torch.Tensor]:
    out = []
    with torch.inference_mode():
        for td in collector:
            out.append(td["action"].clone())
            if len(out) == batches:
                break
    return out


def test_a_batch_is_one_step_of_every_robot_with_its_next_state():
    collector = _collector(total_frames=4 * len(SEEDS))
    assert isinstance(collector, BaseCollector)
    batches = list(collector)  # total_frames ends the iteration
    assert len(batches) == 4
    for td in batches:
        assert td.batch_size == torch.Size([len(SEEDS)])
        assert td["action"].shape == (len(SEEDS), 1)
        # the perception transform wrote the state acted in and the state reached
        assert td["x"].shape == td["next", "x"].shape
    # the next batch starts where the last one arrived
    assert torch.equal(batches[1]["odometry"], batches[0]["next", "odometry"])


def test_robots_whose_trial_ended_restart_before_the_next_batch():
    collector = _collector(max_actions=3)  # every trial is truncated after 3 actions
    with torch.inference_mode():
        batches = [td for _, td in zip(range(4), collector, strict=False)]
    assert batches[2]["next", "truncated"].all()
    start = batches[0]["true_pose"]
    assert torch.equal(batches[3]["true_pose"], start)  # back at the start
    assert not torch.equal(batches[2]["next", "true_pose"], start)


def test_state_dict_round_trip_goes_on_as_the_uninterrupted_collector():
    whole = _actions(_collector(), 12)
    first = _collector()
    _actions(first, 5)
    state = first.state_dict()
    policy_state = first.policy.state_dict()
    drawn = first.policy.random_state()
    resumed = _collector()
    resumed.policy.load_state_dict(policy_state)
    resumed.policy.load_random_state(drawn)
    resumed.load_state_dict(state)
    # the perception's pose tracker holds the trial's keyframes: a working part train.py saves
    # beside the collector's state (``symrl.train.batch_snapshot``), carried over here alike
    resumed.policy.perception.tracker = copy.deepcopy(first.policy.perception.tracker)
    assert state["frames"] == 5 * len(SEEDS)
    rest = _actions(resumed, 7)
    assert all(torch.equal(a, b) for a, b in zip(whole[5:], rest, strict=True))


def test_update_policy_weights_loads_a_module_or_a_state_dict():
    collector, other = _collector(), _collector()
    other.policy.progress.temperature.fill_(0.25)
    collector.update_policy_weights_(other.policy)
    assert torch.equal(collector.policy.progress.temperature, other.policy.progress.temperature)
    collector.update_policy_weights_()  # in-process: nothing to fetch
    assert float(collector.policy.progress.temperature[0]) == 0.25
    other.policy.progress.temperature.fill_(0.5)
    weights = TensorDict(other.policy.state_dict(), batch_size=[]).unflatten_keys(".")
    collector.update_policy_weights_(weights=weights)
    assert float(collector.policy.progress.temperature[0]) == 0.5


def test_shutdown_closes_the_env_once():
    collector = _collector()
    _actions(collector, 1)
    collector.shutdown()
    collector.shutdown()
    assert collector.env.is_closed


def test_the_env_must_have_one_batch_dimension():
    class Flat:
        batch_size = torch.Size([])

    with pytest.raises(ValueError, match=r"batch size \[B\], got \[\]"):
        StepCollector(Flat(), policy=None)  # type: ignore[arg-type]


def test_the_carrier_saved_is_a_plain_dict_of_tensors():
    collector = _collector()
    _actions(collector, 2)
    carrier = collector.state_dict()["carrier"]
    assert isinstance(carrier, dict)
    assert TensorDict(carrier, batch_size=[len(SEEDS)])["sonar"].shape[0] == len(SEEDS)
