"""BatchedWorldEnv: specs, per-robot seeds, partial resets, the reset reward, the Collector loop."""

import math

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.collectors import Collector
from torchrl.envs import EnvBase
from torchrl.envs.utils import RandomPolicy, check_env_specs

from symrl.world.batched_env import BatchedWorldEnv
from symrl.world.env import Hailu2001Env

START = (0.0, 0.0, 0.0)
AT_GOAL = (4.15, -2.0, 0.0)  # 0.15 m from the goal centre: every step ends inside the circle


def actions(values) -> TensorDict:
    values = torch.as_tensor(values, dtype=torch.float32).reshape(-1, 1)
    return TensorDict({"action": values}, batch_size=[len(values)])


@pytest.mark.parametrize("size", [1, 3])  # a batch of one takes the physics' float lane
def test_check_env_specs_and_shapes(size):
    env = BatchedWorldEnv(size=size, seeds=range(size))
    check_env_specs(env)
    td = env.reset()
    assert td.batch_size == torch.Size([size])
    assert td["sonar"].shape == (size, 24) and td["sonar"].dtype == torch.float32
    assert td["true_pose"].shape == (size, 3) and td["true_pose"].dtype == torch.float64
    assert td["state_reward"].shape == (size, 1) and td["collision"].dtype == torch.bool
    td = env.rand_step(td)
    assert td["next", "reward"].shape == (size, 1) and td["next", "done"].shape == (size, 1)
    assert torch.equal(td["next", "reward"], td["next", "state_reward"])
    # no stride-0 axis (torch.stack(..., out=) in the Collector cannot take one)
    assert all(0 not in v.stride() for v in td["next"].values())


def test_robot_b_follows_the_gym_env_seeded_with_its_seed():
    seeds = [5, 6, 7]
    env = BatchedWorldEnv(size=3, seeds=seeds, max_actions=30)
    td = env.reset()
    gym = Hailu2001Env(max_actions=30)
    obs, _ = gym.reset(seed=seeds[1])
    rng = np.random.default_rng(0)
    for _ in range(30):
        for key in obs:
            np.testing.assert_array_equal(td[key][1].numpy(), obs[key])
        alpha = rng.uniform(-1.0, 1.0, 3).astype(np.float32)
        td = env.step(td.set("action", torch.from_numpy(alpha)[:, None]))
        obs, reward, terminated, truncated, info = gym.step(alpha[1:2])
        nxt = td["next"]
        assert nxt["reward"][1, 0].item() == np.float32(reward)
        np.testing.assert_array_equal(nxt["true_pose"][1].numpy(), info["true_pose"])
        assert nxt["terminated"][1, 0].item() == terminated
        assert nxt["truncated"][1, 0].item() == truncated
        td = td["next"].exclude("reward", "done", "terminated", "truncated")
    assert truncated


def test_set_seed_gives_robot_b_the_seed_plus_b():
    a = BatchedWorldEnv(size=3)
    a.set_seed(100)
    b = BatchedWorldEnv(size=3, seeds=[100, 101, 102])
    torch.testing.assert_close(a.reset()["sonar"], b.reset()["sonar"], rtol=0, atol=0)
    c = BatchedWorldEnv(size=3, seeds=[100, 100, 100])  # same seed, same pose: same noise
    sonar = c.reset()["sonar"]
    assert torch.equal(sonar[0], sonar[1]) and torch.equal(sonar[0], sonar[2])


def test_partial_reset_touches_only_the_masked_robots():
    env = BatchedWorldEnv(size=3, seeds=[0, 1, 2])
    td = env.reset()
    for _ in range(4):
        td = env.step(td.set("action", torch.full((3, 1), 0.3)))["next"]
    before = td.clone()
    draws = [rng.bit_generator.state for rng in env.rngs]
    mask = torch.tensor([[False], [True], [False]])
    out = env.reset(td.clone().set("_reset", mask))
    for key in ("true_pose", "sonar", "odometry", "goal", "state_reward"):
        torch.testing.assert_close(out[key][[0, 2]], before[key][[0, 2]], rtol=0, atol=0)
    np.testing.assert_array_equal(out["true_pose"][1].numpy(), START)
    assert env.physics.actions_taken.tolist() == [4, 0, 4]
    # the robots not reset drew nothing; robot 1 drew its reset's sonar noise (no reseeding)
    states = [rng.bit_generator.state for rng in env.rngs]
    assert states[0] == draws[0] and states[2] == draws[2] and states[1] != draws[1]


def test_maybe_reset_equals_torchrl_generic_version():
    """The env's own maybe_reset gives what EnvBase.maybe_reset gives (same seeds, same
    actions, robots ending at different steps), key for key and bit for bit."""
    ours, generic = (BatchedWorldEnv(size=5, seeds=range(5), max_actions=4) for _ in range(2))
    rng = np.random.default_rng(1)
    a, b = ours.reset(), generic.reset()
    restarts = 0
    for i in range(40):
        action = torch.from_numpy(rng.uniform(-1, 1, (5, 1)).astype(np.float32))
        for env in (ours, generic):
            if i % 3 == 0:  # stagger the truncations, so resets are partial
                env.physics.actions_taken[i % 5] += 1
        a = ours.step(a.set("action", action.clone()))
        b = generic.step(b.set("action", action.clone()))
        restarts += int(a["next", "done"].sum())
        na = ours.maybe_reset(ours._step_mdp(a))
        nb = EnvBase.maybe_reset(generic, generic._step_mdp(b))
        assert set(na.keys()) == set(nb.keys())
        for key in sorted(na.keys()):
            assert na[key].dtype == nb[key].dtype and torch.equal(na[key], nb[key]), key
        for key in a.keys(True, True):  # the transition itself is left as it was
            assert torch.equal(a[key], b[key]), key
        a, b = na, nb
    assert 0 < restarts < 40 * 5


class _GenericEnv(BatchedWorldEnv):
    """The same env through TorchRL's generic step_and_maybe_reset and maybe_reset."""

    step_and_maybe_reset = EnvBase.step_and_maybe_reset
    maybe_reset = EnvBase.maybe_reset


def _decisions(rng, size: int) -> dict[str, torch.Tensor]:
    """Keys a policy writes besides the action (float, integer, bool, a row of inputs)."""
    return {
        "action": torch.from_numpy(rng.uniform(-1, 1, (size, 1)).astype(np.float32)),
        "xi": torch.from_numpy(rng.normal(size=size)),
        "winner": torch.from_numpy(rng.integers(-1, 9, size)),
        "novel": torch.from_numpy(rng.random(size) < 0.5),
        "x": torch.from_numpy(rng.normal(size=(size, 4)).astype(np.float32)),
    }


def _assert_same(a: TensorDict, b: TensorDict) -> None:
    assert set(a.keys(True, True)) == set(b.keys(True, True))
    assert a.device == b.device and a.batch_size == b.batch_size
    for key in a.keys(True, True):
        assert a[key].dtype == b[key].dtype and torch.equal(a[key], b[key]), key


def test_step_and_maybe_reset_equals_torchrl_generic_version():
    """The env's own step_and_maybe_reset gives what EnvBase.step_and_maybe_reset (with
    EnvBase.maybe_reset) gives: the transition and the next step's TensorDict, key for key
    and bit for bit, with a policy's extra keys and robots ending at different steps."""
    ours, generic = BatchedWorldEnv, _GenericEnv
    ours, generic = (cls(size=5, seeds=range(5), max_actions=4) for cls in (ours, generic))
    rng = np.random.default_rng(2)
    a, b = ours.reset(), generic.reset()
    restarts = 0
    for i in range(40):
        decisions = _decisions(rng, 5)
        for env in (ours, generic):
            if i % 3 == 0:  # stagger the truncations, so resets are partial
                env.physics.actions_taken[i % 5] += 1
        a.update({k: v.clone() for k, v in decisions.items()})
        b.update({k: v.clone() for k, v in decisions.items()})
        ta, na = ours.step_and_maybe_reset(a)
        tb, nb = generic.step_and_maybe_reset(b)
        restarts += int(ta["next", "done"].sum())
        assert ta is a  # the input becomes the transition, as in TorchRL
        _assert_same(ta, tb)
        _assert_same(na, nb)
        a, b = na, nb
    assert 0 < restarts < 40 * 5


def test_step_and_maybe_reset_takes_torchrl_path_for_other_inputs():
    """A TensorDict without a device, or with a nested entry, steps as TorchRL's path."""
    ours, generic = (cls(size=3, seeds=range(3)) for cls in (BatchedWorldEnv, _GenericEnv))
    ours.reset(), generic.reset()
    rng = np.random.default_rng(3)
    decisions = _decisions(rng, 3)
    for extra in ({}, {"info": TensorDict({"a": torch.ones(3)}, batch_size=[3])}):
        a = TensorDict({**decisions, **extra}, batch_size=[3])
        b = TensorDict({k: v.clone() for k, v in {**decisions, **extra}.items()}, batch_size=[3])
        for x, y in zip(ours.step_and_maybe_reset(a), generic.step_and_maybe_reset(b), strict=True):
            _assert_same(x, y)


def test_a_start_pose_found_valid_is_not_checked_again_but_a_bad_one_still_fails():
    env = BatchedWorldEnv(size=2, seeds=[0, 1])
    env.reset()
    env.set_starts([START, (3.6, -0.5, 0.0)])
    env.reset()
    assert len(env.physics._valid_poses) == 2
    with pytest.raises(ValueError, match=r"\(3\.6, 1\.0, 0\.0\) of robot 1"):
        env.set_starts([START, (3.6, 1.0, 0.0)])


def test_reset_state_reward_by_hand():
    env = BatchedWorldEnv(size=2, noise=False, seeds=[0, 1])
    # robot 1 in the corridor facing away from the goal (4, -2): f2 = -1 exactly; the wall
    # x = 5.55 is 0.29 m from its rim, below d_c = 0.30: f1 = -1 + 0.29 / 0.30
    heading = math.atan2(-2.0, 4.0)  # robot 0 faces the goal in the open: f1 = f2 = 0
    env.set_starts([[0.0, 0.0, heading], [5.0, -2.0, 0.0]])
    td = env.reset()
    f1 = -1.0 + (5.55 - 5.0 - 0.26) / 0.30
    assert td["state_reward"][0, 0].item() == 0.0
    assert td["state_reward"][1, 0].item() == pytest.approx(f1 - 1.0, abs=1e-6)
    assert not td["done"].any()
    env.set_starts(None)
    np.testing.assert_array_equal(env.reset()["true_pose"].numpy(), [START, START])


def test_bad_inputs_raise_one_line_errors():
    env = BatchedWorldEnv(size=3, seeds=[0, 1, 2])
    td = env.reset()
    with pytest.raises(ValueError, match="robot 1 must be finite, got nan") as err:
        env.step(td.set("action", torch.tensor([[0.0], [float("nan")], [0.0]])))
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match=r"\(3\.6, 1\.0, 0\.0\) of robot 2"):
        env.set_starts([START, START, (3.6, 1.0, 0.0)])
    with pytest.raises(ValueError, match="3 seeds"):
        BatchedWorldEnv(size=3, seeds=[0, 1])


def test_collector_restarts_each_robot_on_its_own():
    # robot 0 starts next to the goal (every episode is one step long), robots 1 and 2 at the
    # map start (truncated after 5 actions): the Collector resets each as its episode ends
    size, batches = 3, 12
    env = BatchedWorldEnv(size=size, max_actions=5, seeds=[0, 1, 2])
    env.set_starts([AT_GOAL, START, START])
    collector = Collector(
        env, RandomPolicy(env.action_spec), frames_per_batch=size, total_frames=size * batches
    )
    data = torch.cat([batch.reshape(size, -1) for batch in collector], dim=1)  # (B, T)
    collector.shutdown()
    assert data.shape == (size, batches)
    done = data["next", "done"][..., 0]
    assert done[0].all() and data["next", "terminated"][0].all()
    pattern = torch.tensor([(t + 1) % 5 == 0 for t in range(batches)])
    assert torch.equal(done[1], pattern) and torch.equal(done[2], pattern)
    assert not data["next", "terminated"][1:].any()
    # after each end the robot starts again from its own start pose
    poses = data["true_pose"].numpy()
    for t in range(batches):
        np.testing.assert_array_equal(poses[0, t], AT_GOAL)
        if t % 5 == 0:
            np.testing.assert_array_equal(poses[1, t], START)
            np.testing.assert_array_equal(poses[2, t], START)
        else:
            assert not np.array_equal(poses[1, t], START)


@pytest.mark.parametrize(
    ("action", "message"),
    [
        (torch.zeros(2, 1, dtype=torch.long), "torch.int64 of shape \\(2, 1\\)"),
        (torch.zeros(2, 1, dtype=torch.bool), "expected 2 float rotation"),
        (torch.tensor([[0.1], [math.nan]]), "robot 1 must be finite"),
    ],
)
def test_a_bad_action_is_named(action, message):
    env = BatchedWorldEnv(size=2, seeds=[0, 1])
    td = env.reset()
    with pytest.raises(ValueError, match=message):
        env.step(td.set("action", action))
