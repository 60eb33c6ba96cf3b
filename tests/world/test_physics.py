"""RobotBatch: the scalar model kept bitwise, B-invariance, the reset reward, errors."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.world.env import Hailu2001Env
from symrl.world.geometry import Walls
from symrl.world.physics import Readings, RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import load_map

WORLD = load_map("hailu2001")
NEAR_GOAL = (4.65, 1.0, -1.5)  # in the corridor, heading down towards the goal


def gym_scenario(seed, pose=None, steps=300, **kwargs):
    """A goal-seeking drive with jitter (collisions of both kinds, goals reached), summarised."""
    env = Hailu2001Env(**kwargs)
    opts = None if pose is None else {"pose": pose}
    obs, _ = env.reset(seed=seed, options=opts)
    rng = np.random.default_rng(seed + 100)
    total = obs_sum = 0.0
    real = virtual = reached = 0
    for _ in range(steps):
        a = obs["goal"][1] + 0.8 * rng.uniform(-1.0, 1.0)
        obs, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        total += reward
        obs_sum += float(sum(float(v.astype(np.float64).sum()) for v in obs.values()))
        real += int(info["real_collision"])
        virtual += int(info["virtual_collision"])
        reached += int(terminated)
        if terminated or truncated:
            obs, _ = env.reset(options=opts)
    return total, obs_sum, real, virtual, reached, tuple(env.true_pose.tolist())


# Recorded with the scalar implementation that preceded RobotBatch (same seeds and actions):
# the Gymnasium env must keep reproducing its trajectories bit for bit.
SCALAR_MODEL = [
    (
        (0, None, {}),
        (
            -820.2789809729668,
            93192.33592744582,
            242,
            18,
            0,
            (3.136423151682569, -1.886543388127524, -0.9501890163110644),
        ),
    ),
    (
        (1, NEAR_GOAL, {}),
        (
            -198.4740116211003,
            25270.308278638506,
            18,
            19,
            16,
            (3.8991512749684007, -0.7015978089291971, -1.6508103963664136),
        ),
    ),
    (
        (2, NEAR_GOAL, {"robot": {"sonar_cone_deg": 25.0}}),
        (
            -222.26159715691352,
            23268.129041579497,
            21,
            25,
            16,
            (4.671729873332915, -0.11375271969438533, -1.6408055726675965),
        ),
    ),
    (
        (3, None, {"noise": False}),
        (
            -823.1986771720264,
            95043.24665533206,
            243,
            18,
            0,
            (3.1637665626869405, -1.4908634979311448, -0.4404662810266018),
        ),
    ),
]


@pytest.mark.parametrize(("args", "expected"), SCALAR_MODEL)
def test_gym_env_reproduces_the_scalar_model_bitwise(args, expected):
    seed, pose, kwargs = args
    assert gym_scenario(seed, pose, **kwargs) == expected


# --- B-invariance ---------------------------------------------------------------------------


def row(readings: list[Readings], b: int, batch_rows: list[np.ndarray]) -> list[tuple]:
    """Robot b's values (as bytes) from every Readings that covers it (``batch_rows[i]``: the
    robots Readings i covers)."""
    values = []
    for r, rows in zip(readings, batch_rows, strict=True):
        hit = np.flatnonzero(rows == b)
        if len(hit):
            values.append(tuple(np.asarray(field)[hit[0]].tobytes() for field in r))
    return values


def drive_rows(batch: RobotBatch, seeds, starts, jitter) -> tuple[list[Readings], list]:
    """Reset every robot, then steer each towards the goal plus ``jitter`` (T, B) radians; a
    robot whose episode ended is reset alone (its generator carries on). Returns the readings
    and the robots each covers."""
    rngs = [np.random.default_rng(s) for s in seeds]
    r = batch.reset(np.arange(batch.size), starts, rngs)
    out, rows = [r], [np.arange(batch.size)]
    goal_angle = r.goal[:, 1].astype(np.float64)
    for noise in jitter:
        r = batch.step(goal_angle + noise, rngs)
        out.append(r)
        rows.append(np.arange(batch.size))
        goal_angle = r.goal[:, 1].astype(np.float64)
        ended = np.flatnonzero(r.reached_goal | r.truncated)
        if len(ended):
            r = batch.reset(ended, starts[ended], rngs)
            out.append(r)
            rows.append(ended)
            goal_angle[ended] = r.goal[:, 1]
    return out, rows


@pytest.mark.parametrize("robot", [RobotConfig(), RobotConfig(sonar_cone_deg=25.0)])
def test_a_robot_is_bitwise_the_same_alone_or_at_position_3_of_7(robot):
    steps, b = 400, 3
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (steps, 7))
    seeds = [11, 12, 13, 42, 14, 15, 16]
    starts = np.tile([WORLD.start.x, WORLD.start.y, WORLD.start.heading], (7, 1))
    starts[[1, 3, 5]] = NEAR_GOAL  # robot 3 reaches the goal now and then
    many, many_rows = drive_rows(
        RobotBatch(WORLD, robot, 7, max_actions=60), seeds, starts, actions
    )
    one, one_rows = drive_rows(
        RobotBatch(WORLD, robot, 1, max_actions=60),
        seeds[b : b + 1],
        starts[b : b + 1],
        actions[:, b : b + 1],
    )
    alone = row(one, 0, one_rows)
    in_batch = row(many, b, many_rows)
    assert alone == in_batch
    collisions = sum(bool(r.real_collision[0]) for r in one)
    virtual = sum(bool(r.virtual_collision[0]) for r in one)
    goals = sum(bool(r.reached_goal[0]) for r in one)
    assert collisions > 0 and virtual > 0 and goals > 0  # the run exercised every branch


@settings(max_examples=15, deadline=None)
@given(
    size=st.integers(2, 9),
    data=st.data(),
    seed=st.integers(0, 2**32 - 1),
    noise=st.booleans(),
)
def test_b_invariance_for_any_batch_size_and_position(size, data, seed, noise):
    b = data.draw(st.integers(0, size - 1))
    rng = np.random.default_rng(seed)
    actions = rng.uniform(-math.pi, math.pi, (40, size))
    seeds = rng.integers(0, 2**31, size).tolist()
    starts = np.tile([WORLD.start.x, WORLD.start.y, WORLD.start.heading], (size, 1))
    starts[b] = NEAR_GOAL
    many, many_rows = drive_rows(
        RobotBatch(WORLD, RobotConfig(), size, noise, 15), seeds, starts, actions
    )
    one, one_rows = drive_rows(
        RobotBatch(WORLD, RobotConfig(), 1, noise, 15),
        [seeds[b]],
        starts[b : b + 1],
        actions[:, b : b + 1],
    )
    assert row(one, 0, one_rows) == row(many, b, many_rows)


# --- the Gymnasium env is the batch of one ---------------------------------------------------


def test_gym_env_equals_a_batch_of_one_with_the_same_seed():
    env = Hailu2001Env()
    batch = RobotBatch(WORLD, RobotConfig(), 1)
    rngs = [np.random.default_rng(7)]
    obs, _ = env.reset(seed=7)
    r = batch.reset([0], [[0.0, 0.0, 0.0]], rngs)
    np.testing.assert_array_equal(obs["sonar"], r.sonar[0])
    actions = np.random.default_rng(1).uniform(-1.0, 1.0, 250)
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(np.array([a], np.float32))
        r = batch.step(np.array([np.float32(a)], np.float64), rngs)
        for key in obs:
            np.testing.assert_array_equal(obs[key], getattr(r, key)[0])
        assert reward == r.reward[0] and info["f1"] == r.f1[0] and info["f2"] == r.f2[0]
        np.testing.assert_array_equal(info["true_pose"], r.true_pose[0])
        assert terminated == r.reached_goal[0] and truncated == r.truncated[0]
        assert info["collision"] == r.collision[0]
        if terminated or truncated:
            break


# --- reset readings, errors -------------------------------------------------------------------


def test_reset_reward_is_the_reinforcement_of_the_reset_state():
    # (5.0, -2.0) in the corridor, heading 0: the goal (4.0, -2.0) is straight behind, so
    # f2 = -1 exactly; the right wall x = 5.55 is 0.29 m from the rim (< d_c = 0.30)
    batch = RobotBatch(WORLD, RobotConfig(), 2, noise=False)
    r = batch.reset([1], [[5.0, -2.0, 0.0]], [None, None])
    assert r.f2[0] == -1.0
    rim = 5.55 - 5.0 - 0.26
    assert r.f1[0] == pytest.approx(-1.0 + rim / 0.30, abs=1e-12)
    assert r.reward[0] == r.f1[0] + r.f2[0]
    assert not (r.collision[0] or r.reached_goal[0] or r.truncated[0])
    # in the open, facing the goal: both terms are 0
    heading = math.atan2(-2.0, 4.0)
    r = batch.reset([0], [[0.0, 0.0, heading]], [None, None])
    assert r.f1[0] == 0.0 and r.f2[0] == 0.0


def test_reset_touches_only_its_rows():
    batch = RobotBatch(WORLD, RobotConfig(), 3)
    rngs = [np.random.default_rng(s) for s in range(3)]
    batch.reset([0, 1, 2], np.zeros((3, 3)), rngs)
    for _ in range(5):
        batch.step(np.array([0.3, -0.2, 0.1]), rngs)
    before = batch.true_pose
    r = batch.reset([1], [NEAR_GOAL], rngs)
    after = batch.true_pose
    np.testing.assert_array_equal(after[[0, 2]], before[[0, 2]])
    np.testing.assert_array_equal(r.true_pose[0], NEAR_GOAL)
    assert batch.actions_taken.tolist() == [5, 0, 5]


def test_a_reset_at_a_known_pose_reads_as_the_first_one():
    """Resets at poses sensed before (remembered per pose) give the readings and the state a
    fresh batch gives, bit for bit, alone or with a new pose in the same reset."""
    poses = np.array([[0.0, 0.0, 0.3], [5.0, -2.0, 0.0], [3.0, 1.0, -2.0]])

    def readings(batch, rows, at, seed):
        rngs = [np.random.default_rng(seed + b) for b in range(3)]
        r = batch.reset(rows, at, rngs)
        state = (batch._ex, batch._ey, batch._clear, batch.sonar, batch.true_pose)
        return r, tuple(v[rows].copy() for v in state)  # the reset rows' state

    warm = RobotBatch(WORLD, RobotConfig(), 3)
    warm.reset([0, 1], poses[:2], [np.random.default_rng(9)] * 3)  # poses 0 and 1 remembered
    for rows, at in (([0, 1], poses[:2]), ([1, 2], poses[1:]), ([2], poses[:1])):
        fresh = RobotBatch(WORLD, RobotConfig(), 3)
        r1, s1 = readings(warm, rows, at, 4)
        r2, s2 = readings(fresh, rows, at, 4)
        for a, b in zip((*r1, *s1), (*r2, *s2), strict=True):
            np.testing.assert_array_equal(a, b)


def test_non_finite_action_names_the_robot():
    batch = RobotBatch(WORLD, RobotConfig(), 4)
    rngs = [np.random.default_rng(s) for s in range(4)]
    batch.reset(range(4), np.zeros((4, 3)), rngs)
    with pytest.raises(ValueError, match=r"robot 2 must be finite, got nan") as err:
        batch.step(np.array([0.0, 0.1, np.nan, 0.0]), rngs)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="4 actions"):
        batch.step(np.zeros(3), rngs)


def test_bad_reset_pose_names_the_pose_and_the_robot():
    batch = RobotBatch(WORLD, RobotConfig(), 2)
    with pytest.raises(ValueError, match=r"\(3\.6, 1\.0, 0\.0\) of robot 1 is not in the free"):
        batch.reset([0, 1], [[0.0, 0.0, 0.0], [3.6, 1.0, 0.0]], [None, None])
    with pytest.raises(ValueError, match="too close to a wall"):
        batch.reset([0], [[0.0, 2.4, 0.0]], [None, None])
    with pytest.raises(ValueError, match="finite"):
        batch.reset([0], [[0.0, np.nan, 0.0]], [None, None])


def test_actions_are_clipped_to_pi():
    batch = RobotBatch(WORLD, RobotConfig(), 2, noise=False)
    batch.reset([0, 1], np.zeros((2, 3)), [None, None])
    r = batch.step(np.array([10.0, -10.0]), [None, None])
    assert abs(r.true_pose[0, 2]) == pytest.approx(math.pi)
    assert abs(r.true_pose[1, 2]) == pytest.approx(math.pi)


@settings(max_examples=30, deadline=None)
@given(
    xs=st.lists(st.floats(-1.4, 5.5), min_size=1, max_size=6),
    data=st.data(),
)
def test_batched_geometry_rows_equal_the_scalar_queries(xs, data):
    walls = Walls(WORLD.segments)
    k = len(xs)
    y = np.array(data.draw(st.lists(st.floats(-3.9, 2.4), min_size=k, max_size=k)))
    h = np.array(data.draw(st.lists(st.floats(-math.pi, math.pi), min_size=k, max_size=k)))
    x = np.array(xs)
    offsets = np.radians(15.0 * np.arange(24))
    rays, sectors, clear = walls.scan_many(x, y, h, offsets, 24, 5.26, 0.76)
    for i in range(k):
        r1, s1, c1 = walls.scan(x[i], y[i], h[i], offsets, 24, 5.26, 0.76)
        assert r1.tobytes() == rays[i].tobytes() and c1 == clear[i]
        if s1 is not None:
            assert s1.tobytes() == sectors[i].tobytes()
