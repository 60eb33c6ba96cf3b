"""The perception transform: what the robot makes of each observation, written by the env on
reset (partial resets included) and step, once per observation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from learner_helpers import config_of, paper_trials, policy
from torchrl.envs import TransformedEnv

from symrl.learner.perception import PERCEPTION_KEYS, Perception
from symrl.learner.policy import PerceptionMissing
from symrl.train import make_env
from symrl.world.batched_env import BatchedTransformedEnv

SEEDS = (0, 1, 2)


def _env(p, generic: bool = False):
    env = make_env(config_of(p), SEEDS)
    if generic:  # TorchRL's own TransformedEnv: its generic step, step_mdp and reset
        return TransformedEnv(env, p.perception_transform())
    return env.append_transform(p.perception_transform())


def test_reset_and_step_write_the_perception_on_the_root_and_on_next():
    p = policy("paper_literal", seeds=SEEDS)  # odometry as belief, sensor input
    env = _env(p)
    assert isinstance(env, BatchedTransformedEnv)
    td = env.reset()
    start = p.knowledge.start
    assert td["pose"].tolist() == td["odometry"].tolist()  # no localisation: the odometry
    assert td["region"].tolist() == [p.region_names.index("room")] * 3
    assert torch.equal(td["expert"], td["region"])  # partition
    assert torch.equal(td["x"][:, :24], td["sonar"])
    g = p.knowledge.goal
    rho = math.hypot(g.x - start.x, g.y - start.y) / p.perception.start_distance
    codes = torch.exp(-(((torch.arange(8) / 7 - rho) / config_of(p).experts.goal_code_width) ** 2))
    assert torch.allclose(td["x"][0, 24:], codes, atol=1e-5)
    td["action"] = torch.zeros(3, 1)
    td, following = env.step_and_maybe_reset(td)
    for key in PERCEPTION_KEYS:
        assert key in td["next"] and torch.equal(following[key], td["next", key]), key
    assert torch.equal(td["next", "x"][:, :24], td["next", "sonar"])


def test_the_transforms_step_equals_torchrl_generic_one_with_localisation_and_partial_resets():
    """Same seeds and actions through BatchedTransformedEnv's own step_and_maybe_reset and
    TorchRL's generic TransformedEnv: the transitions and the next TensorDicts are equal key
    for key, bit for bit, with robots restarting at different steps (map localisation, whose
    tracker starts each trial afresh)."""
    recipe = ("paper_map", "env.max_actions=5", "localize.enabled=true")
    ours, theirs = policy(*recipe, seeds=SEEDS), policy(*recipe, seeds=SEEDS)
    assert ours.perception.tracker is not None
    fast, generic = _env(ours), _env(theirs, generic=True)
    a, b = fast.reset(), generic.reset()
    rng = np.random.default_rng(4)
    restarts = 0
    for i in range(24):
        for env in (fast, generic):
            if i % 4 == 0:  # stagger the truncations, so resets are partial
                env.physics.actions_taken[i % 3] += 1
        action = torch.from_numpy(rng.uniform(-1, 1, (3, 1)).astype(np.float32))
        a["action"], b["action"] = action.clone(), action.clone()
        ta, na = fast.step_and_maybe_reset(a)
        tb, nb = generic.step_and_maybe_reset(b)
        restarts += int(ta["next", "done"].sum())
        for x, y in ((ta, tb), (na, nb)):
            assert set(x.keys(True, True)) == set(y.keys(True, True))
            for key in x.keys(True, True):
                assert torch.equal(x[key], y[key]), (i, key)
        a, b = na, nb
    assert 0 < restarts < 24 * 3


def test_a_restarted_robot_is_localised_afresh():
    """Robot 1's trial ends a step before the others': at its reset its belief is that of a
    trial's first observation (the localiser's cold start), whatever its last trial was."""
    p = policy("paper_map", "env.max_actions=3", "localize.enabled=true", seeds=SEEDS)
    assert p.perception.tracker is not None
    env = _env(p)
    td = env.reset()
    env.physics.actions_taken[1] += 1
    for _ in range(2):
        td["action"] = torch.full((3, 1), 0.3)
        _, td = env.step_and_maybe_reset(td)
    assert env.physics.actions_taken.tolist() == [2, 0, 2]
    c = config_of(p)
    fresh = Perception(p.knowledge, 1, c.env.robot, c.experts, c.localize, c.gate.partition)
    one = fresh.perceive(td["sonar"][1:2], td["odometry"][1:2], td["goal"][1:2])
    for key in PERCEPTION_KEYS:
        assert torch.equal(td[key][1:2], one[key]), key


def test_a_policy_on_an_env_without_its_transform_is_a_one_line_error_naming_the_key():
    """The policy reads the transform's keys and does not perceive by itself: on a bare env
    it stops at once, with one line naming the missing key and the fix."""
    p = policy("paper_map", seeds=SEEDS)
    bare = make_env(config_of(p), SEEDS)
    td = bare.reset()
    assert not set(PERCEPTION_KEYS) & set(td.keys())
    with pytest.raises(PerceptionMissing) as err:
        p(td)
    message = str(err.value)
    assert "\n" not in message and "'pose'" in message and "perception transform" in message
    assert "action" not in td  # it wrote nothing
    # the same observation perceived by its transform (a direct call, as the env's)
    p(p.perception_transform()(td))
    assert "action" in td


def test_perception_keys_are_in_the_transformed_specs():
    p = policy("paper_literal", "experts.input=pose", seeds=SEEDS)
    spec = _env(p).observation_spec
    assert spec["x"].shape == (3, 4) and spec["pose"].shape == (3, 3)
    assert spec["region"].dtype == torch.long


def test_is_init_marks_the_first_state_of_each_trial_and_the_policy_begins_it():
    """The transform writes is_init True on the robots a reset restarted (all at the first
    reset, robot 1 alone when its trial ends first), False after a step; the policy forgets
    the per-trial option choices of those robots before acting, and only theirs."""
    p = policy("paper", "env.max_actions=3", seeds=SEEDS)
    assert p.options is not None
    env = _env(p)
    td = env.reset()
    assert td["is_init"].reshape(-1).tolist() == [True] * 3
    env.physics.actions_taken[1] += 1
    for _ in range(2):
        p(td)
        td, td_next = env.step_and_maybe_reset(td)
        assert not td["next", "is_init"].any()
        td = td_next
    assert td["is_init"].reshape(-1).tolist() == [False, True, False]
    p.options.choice.fill_(0)
    p(td)
    choice = p.options.choice
    # robot 1 forgot its choices (it may choose again in the region it starts in)
    assert int((choice[1] == -1).sum()) >= choice.shape[1] - 1
    assert (choice[[0, 2]] == 0).all()


def test_a_paper_trials_record_says_how_far_its_scans_moved_its_belief():
    """`paper` corrects its odometry by its scans: each trial's row has the correction at the
    trial's end (TensorBoard `odometry/scan_correction_m`); without the scan odometry, none."""
    on = paper_trials("tuning/t_wrong_arm", 5000, 2)
    off = paper_trials("tuning/t_wrong_arm", 5000, 1, "scan_odometry.enabled=false")
    assert all(t["scan_correction_m"] > 0.05 for t in on)  # a 16 m route drifts decimetres
    assert "scan_correction_m" not in off[0]
