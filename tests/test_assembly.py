"""The assembly: one place builds a run's env, perception, policy, collector and update, and
each part holds what its recipe's rung tells it and the config sections it uses."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import symrl.train
from symrl.assembly import assemble, assemble_greedy, build_policy, build_update, make_env
from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.scan_odometry import ScanOdometry
from symrl.learner.config import load_config
from symrl.learner.perception import PERCEPTION_KEYS, Perception
from symrl.learner.policy import MixtureOfExpertsPolicy
from symrl.world.worldmap import load_map

SEEDS = [3, 4]


def test_train_builds_its_env_with_the_assemblys_make_env():
    assert symrl.train.make_env is make_env


def test_a_regions_recipe_assembles_parts_that_hold_no_walls():
    """``paper`` (knowledge: regions): the world is cut once, and what the policy, its
    perception and its options hold is the rung's (regions, start, goal; no walls); the env
    keeps the whole world."""
    run = assemble(load_config("paper", ["run.trials=1"]), SEEDS)
    policy, env = run.policy, run.env
    assert policy.knowledge.rung == "regions" and policy.knowledge.world is None
    assert env.world.segments.shape[0] > 0  # the env has the walls
    assert policy.perception_transform() is run.perception
    # no map localiser (it would need the walls): the odometry corrected by the robot's scans
    assert isinstance(run.perception.tracker, ScanOdometry)
    assert policy.options is not None and policy.options.route is None
    assert policy.knowledge.regions == env.world.regions
    with pytest.raises(ValueError, match="knowledge=regions"):
        policy.knowledge.geometry("a test")
    run.collector.shutdown()


def test_told_the_map_the_parts_hold_the_same_world_as_the_env():
    run = assemble(load_config("paper_map", ["localize.enabled=true"]), SEEDS)
    assert run.policy.knowledge.world is run.env.world
    assert run.perception.tracker is not None
    run.collector.shutdown()


def test_the_env_has_the_perception_transform_and_the_update_learns_the_policys_experts():
    config = load_config("paper", ["env.max_actions=30"])
    run = assemble(config, SEEDS)
    assert run.env.transform is run.perception
    assert isinstance(run.perception, Perception)
    td = run.env.reset()
    assert all(key in td for key in PERCEPTION_KEYS)
    assert run.update.policy is run.policy and run.update.experts is run.policy.experts
    assert run.update.progress is run.policy.progress
    assert run.collector.policy is run.policy
    with torch.inference_mode():
        for batch in run.collector:
            stats = run.update(batch)
            break
    assert int(stats["grown"].sum()) > 0  # the first states are novel: neurons grown
    assert int(run.policy.neurons().sum()) == int(stats["neurons"].sum())
    run.collector.shutdown()


def test_the_config_carries_the_envs_step_budget_and_the_check_sees_it():
    seen = []
    config = load_config("paper")
    run = assemble(config, [0], check=lambda c, b, w: seen.append((c, b, w)))
    assert seen == [(run.config, 1, run.env.world)]
    assert run.config.env.max_actions == run.env.physics.max_actions
    run.collector.shutdown()


def test_the_policy_is_handed_its_parts_and_takes_only_the_experts_section():
    config = load_config("paper_map")
    policy = build_policy(config, load_map("hailu2001"), SEEDS)
    assert isinstance(policy, MixtureOfExpertsPolicy) and not hasattr(policy, "config")
    assert policy.experts_config is config.experts
    assert policy.reflex.config == config.reflex
    assert policy.batch == 2 and policy.seeds == SEEDS
    keys = list(policy.state_dict())
    assert any(k.startswith("mapper.") for k in keys) and "code_centres" in keys
    update = build_update(config, policy)
    assert update.settings is config.update and update.gradient is config.trial_gradient


def test_a_perception_for_another_batch_is_refused():
    config = load_config("paper")
    told = Knowledge.told(load_map("hailu2001"), "regions")
    perception = Perception(
        told, 3, config.env.robot, config.experts, config.localize, config.gate.partition
    )
    with pytest.raises(ValueError, match="seeds: 2 robots, but the perception is built for 3"):
        MixtureOfExpertsPolicy(
            told, perception, SEEDS, config.experts, FuzzyReflex(config.reflex), 0.3
        )


def test_greedy_copies_are_told_what_the_controller_learned_in_and_drive_elsewhere():
    config = load_config("paper_map")
    world = load_map("hailu2001")
    boxed = world.with_obstacle([(1.0, 1.0), (1.4, 1.0), (1.4, 1.4), (1.0, 1.4)])
    state = build_policy(config, world, [0]).robot_state(0)
    policy, env = assemble_greedy(config, world, [state, state], [7, 7], boxed, env_seeds=[1, 2])
    try:
        assert policy.knowledge.world is world and env.world is boxed
        assert env.transform is policy.perception_transform()
        assert policy.seeds == [7, 7]  # the policy's streams; the env's robots: env_seeds
        first = [float(g.random()) for g in env.base_env.rngs]
        assert first == [float(np.random.default_rng(s).random()) for s in (1, 2)]
    finally:
        env.close()


def test_the_policy_reads_the_transforms_keys_and_not_the_raw_pose_or_goal():
    """What the policy acts on is its perception's: the odometry and the goal reading taken out
    of the TensorDict change nothing."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    run = assemble(load_config("paper_map"), SEEDS)
    policy = run.policy
    assert set(policy.in_keys) == {"sonar", "ir", "state_reward", "is_init", *PERCEPTION_KEYS}
    td = run.env.reset()
    bare = td.clone().exclude("odometry", "goal")
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        full = policy(td.clone())
        policy.begin_trial(torch.arange(len(SEEDS)))
        cut = policy(bare)
    for key in ("action", "winner", "aim", "option"):
        assert torch.equal(full[key], cut[key]), key
    run.collector.shutdown()
