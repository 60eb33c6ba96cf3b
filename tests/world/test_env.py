"""The Gymnasium env: hand-computed sensing and rewards, collisions, determinism, API checks."""

import math
import pickle
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st

import symrl
from symrl.world.env import Hailu2001Env
from symrl.world.robot import RobotConfig

R = 0.26  # robot radius
GOAL = (4.0, -2.0)


def make(**kwargs) -> Hailu2001Env:
    return Hailu2001Env(**kwargs)


def at(pose, **kwargs) -> tuple[Hailu2001Env, dict]:
    env = make(noise=False, **kwargs)
    obs, _ = env.reset(seed=0, options={"pose": pose})
    return env, obs


def f2_by_hand(x: float, y: float, heading: float) -> float:
    diff = abs(heading - math.atan2(GOAL[1] - y, GOAL[0] - x)) % (2 * math.pi)
    return -min(diff, 2 * math.pi - diff) / math.pi


# --- sensing -------------------------------------------------------------------------------


def test_sonar_at_the_start_by_hand():
    _, obs = at((0.0, 0.0, 0.0))
    sonar = obs["sonar"] * 5.0
    # ahead the dividing wall x = 3.5, behind x = -1.5, left/right y = +-2.5 (rim = centre - 0.26)
    np.testing.assert_allclose(sonar[[0, 6, 12, 18]], [3.24, 2.24, 1.24, 2.24], atol=1e-6)
    # 45 deg: the top wall at (2.5, 2.5); 135 deg: the left wall at (-1.5, 1.5)
    np.testing.assert_allclose(sonar[3], 2.5 * math.sqrt(2) - R, atol=1e-6)
    np.testing.assert_allclose(sonar[9], 1.5 * math.sqrt(2) - R, atol=1e-6)
    np.testing.assert_allclose(sonar[21], sonar[3], atol=1e-6)  # mirror image
    assert np.all(obs["ir"] == 0.0)  # every wall is > 0.76 m away


def test_sonar_rotates_with_the_heading_and_is_capped():
    _, obs = at((0.0, 0.0, math.pi / 2))  # facing +y: ray 0 now sees the top wall
    np.testing.assert_allclose(obs["sonar"][[0, 6, 18]] * 5, [2.24, 1.24, 3.24], atol=1e-6)
    # along y = -0.5 the ray passes the door to x = 5.55: 6.75 - 0.26 > 5 m, capped
    _, obs = at((-1.2, -0.5, 0.0))
    assert obs["sonar"][0] == pytest.approx(1.0)
    _, obs = at((2.0, -0.5, 0.0))  # through the door: 3.55 - 0.26
    assert obs["sonar"][0] * 5 == pytest.approx(3.29, abs=1e-6)


def test_sonar_in_the_corridor_by_hand():
    _, obs = at((4.65, -2.0, math.pi / 2))
    np.testing.assert_allclose(
        obs["sonar"][[0, 6, 12, 18]] * 5, [4.5 - R, 0.9 - R, 2.0 - R, 0.9 - R], atol=1e-6
    )


def test_ir_near_the_top_wall_by_hand():
    # centre 0.36 m below y = 2.5: rim distance 0.10 in sector 6 (90 deg); sector k sees the
    # wall first at its edge nearest to 90 deg, at 0.36 / sin(edge) from the centre
    _, obs = at((0.0, 2.5 - 0.36, 0.0))
    ir = obs["ir"]

    def refl(d):
        return 100.0 * (1.0 - d / 0.5) ** 3 if d < 0.5 else 0.0

    assert ir[6] == pytest.approx(refl(0.10), rel=1e-5)  # 51.2
    assert ir[6] == pytest.approx(51.2, rel=1e-5)
    for k, edge in ((5, 82.5), (4, 67.5), (3, 52.5), (2, 37.5)):
        expected = refl(0.36 / math.sin(math.radians(edge)) - R)
        assert ir[k] == pytest.approx(expected, rel=1e-4), k
        assert ir[12 - k] == pytest.approx(expected, rel=1e-4), 12 - k
    assert ir[1] == 0.0 and ir[11] == 0.0
    assert np.all(ir[13:] == 0.0)


def test_virtual_collision_threshold_is_0_056_m():
    assert RobotConfig().ir_collision_distance == pytest.approx(0.5 * (1 - 0.7 ** (1 / 3)))
    assert RobotConfig().ir_collision_distance == pytest.approx(0.056, abs=5e-4)


# --- collisions and rewards -------------------------------------------------------------------


def test_driving_into_a_wall_is_a_real_collision_and_reverses():
    start = (0.0, 2.5 - R - 0.10, math.pi / 2)  # rim 0.10 m from the top wall, facing it
    env, _ = at(start)
    obs, reward, terminated, truncated, info = env.step(np.array([0.0], np.float32))
    assert info["real_collision"] and info["collision"] and not info["virtual_collision"]
    assert obs["bumper"][0] == 1.0
    assert info["f1"] == -3.0
    np.testing.assert_allclose(info["true_pose"], start)  # reversed to the pose before
    np.testing.assert_allclose(obs["odometry"], start, atol=1e-6)  # the odometry too
    assert reward == pytest.approx(-3.0 + f2_by_hand(*start))
    assert not terminated and not truncated


def test_rotation_is_kept_after_the_emergency_reverse():
    env, _ = at((0.0, 2.5 - R - 0.10, math.pi / 2))
    # turn 10 deg left and drive: still into the wall
    _, _, _, _, info = env.step(np.array([math.radians(10)], np.float32))
    assert info["real_collision"]
    np.testing.assert_allclose(info["true_pose"], [0.0, 2.5 - R - 0.10, math.radians(100)])


def test_ending_within_0_056_m_of_a_wall_is_a_virtual_collision():
    start = (0.0, 2.5 - R - 0.23, math.pi / 2)  # after 0.20 m the rim is 0.03 m from the wall
    env, _ = at(start)
    obs, _, _, _, info = env.step(np.array([0.0], np.float32))
    assert info["virtual_collision"] and info["collision"] and not info["real_collision"]
    assert obs["bumper"][0] == 0.0
    assert info["f1"] == -3.0
    np.testing.assert_allclose(info["true_pose"], start)


def test_f1_close_to_a_wall_and_f2_by_hand():
    # after the move the rim is 0.20 m below the top wall, facing it: f1 = -1 + 0.2 / 0.3
    start = (0.0, 2.5 - R - 0.40, math.pi / 2)
    env, _ = at(start)
    obs, reward, _, _, info = env.step(np.array([0.0], np.float32))
    assert not info["collision"]
    assert obs["sonar"].min() * 5 == pytest.approx(0.20, abs=1e-6)
    assert info["f1"] == pytest.approx(-1.0 + 0.20 / 0.30, abs=1e-5)
    after = (0.0, 2.5 - R - 0.20, math.pi / 2)
    assert info["f2"] == pytest.approx(f2_by_hand(*after))
    assert info["f2"] == pytest.approx(-(math.pi / 2 + math.atan2(4.04, 4.0)) / math.pi)
    assert reward == pytest.approx(info["f1"] + info["f2"])


def test_f1_is_zero_in_the_open_and_f2_uses_the_heading_after_the_action():
    env, _ = at((0.0, 0.0, 0.0))
    obs, reward, _, _, info = env.step(np.array([-0.5], np.float32))
    x, y = 0.2 * math.cos(-0.5), 0.2 * math.sin(-0.5)
    np.testing.assert_allclose(info["true_pose"], [x, y, -0.5], atol=1e-12)
    assert info["f1"] == 0.0
    assert info["f2"] == pytest.approx(f2_by_hand(x, y, -0.5))
    dist = math.hypot(GOAL[0] - x, GOAL[1] - y)
    angle = math.atan2(GOAL[1] - y, GOAL[0] - x) + 0.5
    np.testing.assert_allclose(obs["goal"], [dist, angle], rtol=1e-6)


def test_goal_reached_terminates_on_the_true_pose():
    # 0.583 m from the goal, heading at it: 0.2 m on is inside the 0.40 m circle
    env, _ = at((4.3, -1.5, math.atan2(-0.5, -0.3)))
    _, _, terminated, truncated, info = env.step(np.array([0.0], np.float32))
    assert terminated and not truncated and info["reached_goal"]


def test_truncation_after_max_actions():
    env, _ = at((0.0, 0.0, 0.0), max_actions=5)
    flags = []
    for _ in range(5):
        _, _, terminated, truncated, _ = env.step(np.array([math.pi / 2], np.float32))
        flags.append((terminated, truncated))
    assert flags == [(False, False)] * 4 + [(False, True)]


def test_odometry_drifts_with_noise_and_not_with_perfect_odometry():
    env = make()
    env.reset(seed=3)
    for _ in range(20):
        env.step(np.array([0.05], np.float32))
    assert np.linalg.norm(env.true_pose[:2] - env.odometry_pose[:2]) > 1e-4
    env = make(robot={"perfect_odometry": True})
    env.reset(seed=3)
    for _ in range(20):
        env.step(np.array([0.05], np.float32))
    np.testing.assert_array_equal(env.true_pose, env.odometry_pose)


def test_noise_is_a_sample_not_a_constant():
    env = make()
    first = env.reset(seed=0)[0]["sonar"]
    second = env.reset(seed=1)[0]["sonar"]
    third = env.reset(seed=0)[0]["sonar"]
    np.testing.assert_array_equal(first, third)
    diff = (first - second) * 5.0  # same pose: only the sonar noise differs, std 0.01 * sqrt(2)
    assert 0.005 < np.std(diff) < 0.03


# --- the true pose is never inside a wall -------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(
    start=st.tuples(st.floats(-1.5, 5.55), st.floats(-4.0, 2.5), st.floats(-math.pi, math.pi)),
    actions=st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=60),
    seed=st.integers(0, 2**16),
)
def test_robot_never_inside_a_wall(start, actions, seed):
    env = make()
    x, y, _ = start
    if not env.world.in_free_area(x, y) or env.clearance(x, y) <= R:
        with pytest.raises(ValueError, match="pose"):
            env.reset(seed=seed, options={"pose": start})
        return
    obs, _ = env.reset(seed=seed, options={"pose": start})
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        px, py, _ = info["true_pose"]
        assert env.world.in_free_area(px, py)
        assert env.clearance(px, py) >= R
        assert env.observation_space.contains(obs)
        assert -4.0 <= reward <= 0.0
        if terminated or truncated:
            break


# --- API ------------------------------------------------------------------------------------


def test_registered_and_makes_with_kwargs():
    env = gymnasium.make(symrl.ENV_ID, noise=False, robot={"sonar_cone_deg": 25.0})
    obs, info = env.reset(seed=0)
    assert set(obs) == {"sonar", "ir", "bumper", "odometry", "goal"}
    assert set(info) == {
        "true_pose",
        "collision",
        "real_collision",
        "virtual_collision",
        "f1",
        "f2",
        "reached_goal",
    }
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert all(v.dtype == np.float32 for v in obs.values())
    assert isinstance(info["collision"], np.bool_) and isinstance(info["f1"], np.float64)
    assert info["true_pose"].dtype == np.float64 and info["true_pose"].shape == (3,)


def test_sonar_cone_reads_no_more_than_a_thin_ray():
    thin, cone = at((1.0, 1.0, 0.3))[1], at((1.0, 1.0, 0.3), robot={"sonar_cone_deg": 25.0})[1]
    assert np.all(cone["sonar"] <= thin["sonar"] + 1e-7)
    assert np.any(cone["sonar"] < thin["sonar"] - 1e-3)


def test_check_env_passes():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(gymnasium.make(symrl.ENV_ID, render_mode="rgb_array").unwrapped)
    messages = [str(w.message) for w in caught]
    # the action range [-pi, pi] is the paper's, on purpose
    assert [m for m in messages if "symmetric and normalized" not in m] == []


def rollout(env: Hailu2001Env, seed: int, n: int = 40):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    actions = np.random.default_rng(123).uniform(-1.0, 1.0, n)
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        out.append((obs, reward, info["true_pose"]))
        if terminated or truncated:
            break
    return out


def assert_same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        if isinstance(x, dict):
            for k in x:
                np.testing.assert_array_equal(x[k], y[k])
        else:
            for k in x[0]:
                np.testing.assert_array_equal(x[0][k], y[0][k])
            assert x[1] == y[1]
            np.testing.assert_array_equal(x[2], y[2])


def test_same_seed_same_trajectory():
    assert_same(rollout(make(), 7), rollout(make(), 7))
    with pytest.raises(AssertionError):
        assert_same(rollout(make(), 7), rollout(make(), 8))


def test_noise_off_is_deterministic_whatever_the_seed():
    a, b = rollout(make(noise=False), 1), rollout(make(noise=False), 999)
    assert_same(a, b)
    env = make(noise=False)
    rollout(env, 5)
    np.testing.assert_array_equal(env.true_pose, env.odometry_pose)


def test_pickle_round_trip_continues_identically():
    env = make()
    env.reset(seed=11)
    for a in (0.3, -0.2, 0.1):
        env.step(np.array([a], np.float32))
    clone = pickle.loads(pickle.dumps(env))
    for a in (0.5, -0.4, 0.0, 1.0):
        o1, r1, *_, i1 = env.step(np.array([a], np.float32))
        o2, r2, *_, i2 = clone.step(np.array([a], np.float32))
        assert r1 == r2
        np.testing.assert_array_equal(o1["sonar"], o2["sonar"])
        np.testing.assert_array_equal(i1["true_pose"], i2["true_pose"])
    assert env.path == clone.path


def test_path_and_state_attributes():
    env, _ = at((0.0, 0.0, 0.0))
    env.step(np.array([0.0], np.float32))
    assert env.path == [(0.0, 0.0), (pytest.approx(0.2), 0.0)]
    assert len(env.odometry_path) == 2
    assert env.actions_taken == 1


@pytest.mark.parametrize(
    "pose",
    [(3.6, 1.0, 0.0), (-3.0, 0.0, 0.0), (0.0, 2.4, 0.0), (3.62, -0.5 + 0.3, 0.0), (9.0, 9.0, 0.0)],
)
def test_reset_inside_or_too_close_to_a_wall_raises(pose):
    env = make()
    with pytest.raises(ValueError, match=re_escape(pose)):
        env.reset(options={"pose": pose})


def re_escape(pose) -> str:
    import re

    return re.escape(repr(pose))


def test_reset_rejects_malformed_poses_and_options():
    env = make()
    with pytest.raises(ValueError, match="pose"):
        env.reset(options={"pose": (0.0, float("nan"), 0.0)})
    with pytest.raises(ValueError, match="pose"):
        env.reset(options={"pose": "here"})
    with pytest.raises(ValueError, match="unknown option"):
        env.reset(options={"start": (0.0, 0.0, 0.0)})


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises(bad):
    env = make()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([bad], np.float32))


def test_action_of_wrong_size_raises_and_large_actions_are_clipped():
    env, _ = at((0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([0.1, 0.2], np.float32))
    env.step(np.array([10.0], np.float32))
    assert env.true_pose[2] == pytest.approx(-math.pi) or env.true_pose[2] == pytest.approx(math.pi)


def test_constructor_errors_name_the_argument():
    with pytest.raises(ValueError, match="max_actions"):
        make(max_actions=0)
    with pytest.raises(ValueError, match="render_mode"):
        make(render_mode="ascii")
    with pytest.raises(ValueError, match="radiu"):
        make(robot={"radiu": 0.3})
    with pytest.raises(ValueError, match="radius"):
        make(robot={"radius": -0.3})


def test_a_long_random_drive_collides_both_ways_and_keeps_its_distance():
    env = make(max_actions=10_000)
    env.reset(seed=5)
    rng = np.random.default_rng(5)
    safe = R + env.robot.ir_collision_distance
    real = virtual = 0
    for a in rng.uniform(-1.2, 1.2, 1500):
        _, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        if terminated or truncated:  # the drive goes on from the start
            env.reset()
        real += int(info["real_collision"])
        virtual += int(info["virtual_collision"])
        assert (reward <= -3.0) == bool(info["collision"])
        # every accepted pose keeps the IR safety distance (the start is far from walls)
        assert env.clearance(*info["true_pose"][:2]) >= safe - 1e-9
    assert real > 0 and virtual > 0


def test_no_tunnelling_through_a_thin_wall_with_long_steps():
    world = {
        "boundary": [[0, 0], [4, 0], [4, 2], [0, 2]],
        "segments": [[[2.0, 0.0], [2.0, 1.2]]],  # the 0.8 m gap above lets a B21 through
        "start": {"x": 1.7, "y": 1.0},
        "goal": {"x": 3.5, "y": 1.0, "radius": 0.2},
        "regions": {"names": ["all"], "lines": {}, "rules": [{"region": "all"}]},
    }
    env = make(map=world, noise=False, robot={"radius": 0.1, "step": 0.6})
    env.reset(seed=0)
    # 0.3 m before the wall, a 0.6 m step would jump the disc clean over it
    _, _, _, _, info = env.step(np.array([0.0], np.float32))
    assert info["real_collision"]
    np.testing.assert_allclose(info["true_pose"], [1.7, 1.0, 0.0])


def test_step_after_the_episode_ended_needs_a_reset():
    env = make(max_actions=2, noise=False)
    env.reset(seed=0)
    env.step(np.array([0.0], np.float32))
    *_, truncated, _ = env.step(np.array([0.0], np.float32))
    assert truncated
    with pytest.raises(gymnasium.error.ResetNeeded, match="call reset") as err:
        env.step(np.array([0.0], np.float32))
    assert "\n" not in str(err.value)
    env.reset(seed=0)
    env.step(np.array([0.0], np.float32))  # a reset starts a new episode
