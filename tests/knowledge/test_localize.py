"""Map localisation: from a drifted odometry pose and a sonar scan, the pose the scan was taken
from; the range derivative it uses; its mirror symmetry; what it does without information."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symrl.knowledge.localize import MapLocalizer, PoseTracker
from symrl.world import load_map
from symrl.world.geometry import Walls
from symrl.world.physics import RobotBatch, wrap_angle
from symrl.world.robot import RobotConfig

ROBOT = RobotConfig()
WORLD = load_map("hailu2001")
WALLS = Walls(WORLD.segments)
N = ROBOT.n_sensors
OFFSETS = np.arange(N) * (2 * math.pi / N)


def scan(walls: Walls, pose: np.ndarray) -> np.ndarray:
    """The noise-free normalised sonar readings at poses (B, 3), as the physics computes them."""
    rays = walls.cast_many(
        pose[:, 0], pose[:, 1], pose[:, 2:3] + OFFSETS, ROBOT.radius + ROBOT.sonar_range
    )
    rim = np.clip(rays - ROBOT.radius, 0.0, ROBOT.sonar_range)
    return rim / ROBOT.sonar_range


def free_pose(x: float, y: float, h: float) -> np.ndarray:
    return np.array([[x, y, h]])


def test_cast_with_walls_gives_the_same_distances_and_the_wall_hit():
    rng = np.random.default_rng(0)
    x, y = rng.uniform(0.0, 4.0, 6), rng.uniform(-3.0, 1.5, 6)
    angles = rng.uniform(-math.pi, math.pi, (6, 24))
    plain = WALLS.cast_many(x, y, angles, 5.26)
    t, wall = WALLS.cast_many_walls(x, y, angles, 5.26)
    assert np.array_equal(t, plain)
    hit = wall >= 0
    # the hit point lies on the wall it names
    px, py = x[:, None] + t * np.cos(angles), y[:, None] + t * np.sin(angles)
    seg = WALLS.segments[wall[hit]]
    ax, ay, bx, by = seg.T
    cross = (bx - ax) * (py[hit] - ay) - (by - ay) * (px[hit] - ax)
    assert np.allclose(cross / np.hypot(bx - ax, by - ay), 0.0, atol=1e-9)
    assert np.all(t[~hit] == 5.26)


def test_range_derivative_matches_central_differences():
    loc = MapLocalizer(WALLS, ROBOT)
    pose = np.array([[1.0, -1.0, 0.3], [3.5, -2.5, 2.0]])
    angles = pose[:, 2:3] + OFFSETS
    t, wall = WALLS.cast_many_walls(pose[:, 0], pose[:, 1], angles, loc.cast_range)
    d_x, d_y = loc.wall_dx[wall], loc.wall_dy[wall]
    ux, uy = np.cos(angles), np.sin(angles)
    cross = ux * d_y - uy * d_x
    analytic = np.stack((-d_y / cross, d_x / cross, t * (ux * d_x + uy * d_y) / cross), -1)
    eps = 1e-6
    for i in range(3):
        step = np.zeros(3)
        step[i] = eps
        up, _ = WALLS.cast_many_walls(*(pose + step)[:, :2].T, angles + step[2], loc.cast_range)
        down, _ = WALLS.cast_many_walls(*(pose - step)[:, :2].T, angles - step[2], loc.cast_range)
        numeric = (up - down) / (2 * eps)
        same_wall = wall >= 0
        # rays near a vertex can switch walls within eps: compare where the difference is smooth
        smooth = same_wall & (np.abs(numeric) < 1e3)
        assert np.allclose(analytic[..., i][smooth], numeric[smooth], rtol=1e-4, atol=1e-4)


@settings(max_examples=30, deadline=None)
@given(
    x=st.floats(0.2, 3.5),
    y=st.floats(-1.5, 1.2),
    h=st.floats(-math.pi, math.pi),
    ex=st.floats(-0.25, 0.25),
    ey=st.floats(-0.25, 0.25),
    eh=st.floats(-0.08, 0.08),
)
def test_a_drifted_odometry_is_corrected_to_the_pose_of_the_scan(x, y, h, ex, ey, eh):
    """In the paper's room (0.2-3.5 m, away from the walls), with exact readings and an odometry
    off by up to 0.35 m and 4.6 degrees, the estimate is within 2 cm and 0.6 degrees of the true
    pose (by the door posts a start that far off can settle 1-1.5 cm away; from a few
    centimetres, as along a trial, it is exact: the tracker's test)."""
    true = free_pose(x, y, h)
    if WALLS.clearance(true[:, :2])[0] < ROBOT.radius + 0.05:
        return
    odometry = true + np.array([[ex, ey, eh]])
    estimate = MapLocalizer(WALLS, ROBOT)(odometry, scan(WALLS, true))
    assert math.dist(estimate[0, :2], true[0, :2]) < 0.02
    assert abs(wrap_angle(estimate[0, 2] - h)) < math.radians(0.6)


def test_a_ray_at_a_corner_does_not_hold_the_estimate():
    """At the centre of the paper's square room four rays point into corners at once when the
    heading is 1.2 degrees off; the range's derivative jumps there, and a Gauss-Newton step that
    used those rays stalled at that heading (from any start 1.7-3.6 degrees off). Rays that hit
    within 5 cm of a wall's end are left out, and the estimate is the true pose."""
    true = free_pose(1.0, 0.0, -1.03125)
    for heading_error in (-0.0625, -0.03):
        odometry = true + np.array([[0.0, 0.0, heading_error]])
        estimate = MapLocalizer(WALLS, ROBOT)(odometry, scan(WALLS, true))
        assert np.allclose(estimate, true, atol=1e-4)
    odometry = true + np.array([[0.0, 0.0, -0.0625]])
    stalled = MapLocalizer(WALLS, ROBOT, edge=0.0)(odometry, scan(WALLS, true))
    assert abs(wrap_angle(stalled[0, 2] - true[0, 2])) > 0.01


def test_the_true_pose_is_a_fixed_point_and_noise_moves_it_by_millimetres():
    rng = np.random.default_rng(1)
    true = np.array([[1.0, -1.0, 0.3], [2.5, 0.5, -2.0], [4.3, -2.8, 1.4]])
    exact = scan(WALLS, true)
    loc = MapLocalizer(WALLS, ROBOT)
    assert np.allclose(loc(true, exact), true, atol=1e-9)
    noisy = exact + ROBOT.sonar_noise_std * rng.standard_normal(exact.shape) / ROBOT.sonar_range
    assert np.abs(loc(true, noisy) - true)[:, :2].max() < 0.01


def test_a_mirrored_world_gives_the_mirrored_pose():
    mirrored = WORLD.segments * np.array([1.0, -1.0, 1.0, -1.0])
    walls_m = Walls(mirrored)
    true = np.array([[1.2, -0.6, 0.4]])
    odometry = true + np.array([[0.12, -0.08, 0.05]])
    flip = np.array([1.0, -1.0, -1.0])
    readings = scan(WALLS, true)
    # ray k of the mirrored robot looks where ray -k of the robot looks
    readings_m = readings[:, (-np.arange(N)) % N]
    a = MapLocalizer(WALLS, ROBOT)(odometry, readings)
    b = MapLocalizer(walls_m, ROBOT)(odometry * flip, readings_m)
    assert np.allclose(b, a * flip, atol=1e-9)


def test_without_information_the_odometry_stands():
    """Every reading at the sonar's range says nothing about the pose: the estimate is the
    odometry's."""
    odometry = np.array([[1.0, -1.0, 0.3]])
    out = MapLocalizer(WALLS, ROBOT)(odometry, np.ones((1, N)))
    assert np.allclose(out, odometry, rtol=0, atol=1e-12)


def test_a_scan_with_one_stray_reading_still_gives_the_pose():
    """A reading far off its prediction (an obstacle the map does not hold) counts for little."""
    true = np.array([[1.5, -0.8, 1.0]])
    readings = scan(WALLS, true)
    readings[0, 5] *= 0.3
    out = MapLocalizer(WALLS, ROBOT)(true + np.array([[0.1, 0.1, 0.02]]), readings)
    assert math.dist(out[0, :2], true[0, :2]) < 0.03


def test_a_reading_beyond_outlier_counts_as_if_it_were_not_there():
    """With ``outlier``, a reading mispredicted by more than it gives the estimate of the scan
    without it (a reading at the sonar's range says nothing); without, it still pulls."""
    true = np.array([[1.5, -0.8, 1.0]])
    readings = scan(WALLS, true)
    start = true + np.array([[0.05, -0.04, 0.02]])
    stray, gone = readings.copy(), readings.copy()
    stray[0, 5] *= 0.3  # metres short: a wall the map does not hold
    gone[0, 5] = 1.0
    assert abs(readings[0, 5] - stray[0, 5]) * ROBOT.sonar_range > 0.5
    cut = MapLocalizer(WALLS, ROBOT, iterations=1, outlier=0.5)
    assert np.allclose(cut(start, stray), cut(start, gone), rtol=0, atol=1e-12)
    huber = MapLocalizer(WALLS, ROBOT, iterations=1)
    assert not np.allclose(huber(start, stray), huber(start, gone), rtol=0, atol=1e-6)
    # readings within it count as before
    assert np.allclose(cut(start, readings), huber(start, readings), rtol=0, atol=1e-12)


def test_one_step_moves_the_pose_at_most_max_move_toward_the_scans_pose():
    """A trust region: an estimate 0.4 m off is pulled back by 0.1 m a step, along the full
    step's direction, and gets there in a few steps."""
    true = np.array([[1.5, -0.8, 1.0]])
    readings = scan(WALLS, true)
    odometry = true + np.array([[0.4, -0.2, 0.05]])
    free = MapLocalizer(WALLS, ROBOT, iterations=1, prior_xy=5.0, max_move=None)(odometry, readings)
    bounded = MapLocalizer(WALLS, ROBOT, iterations=1, prior_xy=5.0)(odometry, readings)
    assert math.dist(free[0, :2], odometry[0, :2]) > 0.2
    step, full = bounded[0] - odometry[0], free[0] - odometry[0]
    assert math.hypot(*step[:2]) == pytest.approx(0.1, abs=1e-9)
    assert step == pytest.approx(full * 0.1 / math.hypot(*full[:2]), abs=1e-9)  # same direction
    many = MapLocalizer(WALLS, ROBOT, iterations=8, prior_xy=5.0)(odometry, readings)
    assert math.dist(many[0, :2], true[0, :2]) < 0.01


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"iterations": 0}, "iterations"),
        ({"prior_xy": 0.0}, "prior_xy"),
        ({"huber": -1.0}, "huber"),
        ({"edge": -0.1}, "edge"),
        ({"max_move": 0.0}, "max_move"),
        ({"outlier": 0.0}, "outlier"),
    ],
)
def test_bad_settings_are_named(kwargs, field):
    with pytest.raises(ValueError, match=field):
        MapLocalizer(WALLS, ROBOT, **kwargs)


def _drive(batch: int, steps: int, seed: int = 0):
    """Noisy robots of the physics driven toward the goal by their odometry: per step the
    odometry, the sonar and the true poses (B, 3), (B, n), (B, 3)."""
    physics = RobotBatch(WORLD, ROBOT, batch, noise=True)
    rngs = [np.random.default_rng(seed + b) for b in range(batch)]
    start = np.tile([WORLD.start.x, WORLD.start.y, WORLD.start.heading], (batch, 1))
    r = physics.reset(np.arange(batch), start, rngs)
    turn = np.random.default_rng(seed).normal(0.0, 0.3, (steps, batch))
    out = [(r.odometry, r.sonar, r.true_pose)]
    for k in range(steps):
        g = WORLD.goal
        bearing = np.arctan2(g.y - r.odometry[:, 1], g.x - r.odometry[:, 0]) - r.odometry[:, 2]
        r = physics.step(np.clip(wrap_angle(bearing), -0.6, 0.6) + turn[k], rngs)
        out.append((r.odometry, r.sonar, r.true_pose))
    return out


def test_the_tracker_follows_the_true_pose_while_the_odometry_drifts():
    tracker = PoseTracker(MapLocalizer(WALLS, ROBOT), 8)
    drift, error = [], []
    for odometry, sonar, true in _drive(8, 40):
        pose = tracker(odometry, sonar)
        drift.append(np.hypot(*(odometry[:, :2] - true[:, :2]).T).max())
        error.append(np.hypot(*(pose[:, :2] - true[:, :2]).T).max())
    assert max(drift) > 0.05  # the odometry has drifted by centimetres
    assert max(error) < 0.03 and np.mean(error) < 0.01


def test_the_tracker_keeps_its_correction_through_scans_without_information():
    # the prior is the last belief moved by the odometry's increment, not the raw odometry: a
    # scan that says nothing (every reading at the range cap) leaves the belief where the
    # odometry's increments carry the last one, the correction kept (a prior on the raw
    # odometry would pull the belief back onto its drift)
    tracker = PoseTracker(MapLocalizer(WALLS, ROBOT), 1)
    true = free_pose(WORLD.start.x, WORLD.start.y, WORLD.start.heading)
    first = tracker(true + np.array([[0.12, 0.0, 0.0]]), scan(WALLS, true).astype(np.float32))
    correction = first - (true + np.array([[0.12, 0.0, 0.0]]))
    assert correction[0, 0] < -0.1  # the scan put the belief back near the true pose
    blind = np.ones((1, N), dtype=np.float32)
    for k in range(1, 11):
        odometry = true + np.array([[0.12 + 0.05 * k, 0.02 * k, 0.0]])
        pose = tracker(odometry, blind)
        np.testing.assert_allclose(pose - odometry, correction, atol=1e-6)  # float32 observations


def test_a_robot_believes_the_same_alone_and_in_a_batch():
    steps = _drive(5, 25, seed=3)
    together = PoseTracker(MapLocalizer(WALLS, ROBOT), 5)
    alone = PoseTracker(MapLocalizer(WALLS, ROBOT), 1)
    for k, (odometry, sonar, _) in enumerate(steps):
        if k == 10:  # robots 0 and 3 start a new trial in the batch; robot 3 alone too
            together.begin_trial(np.array([0, 3]))
            alone.begin_trial(np.array([0]))
        batch = together(odometry, sonar)
        assert np.array_equal(batch[3:4], alone(odometry[3:4], sonar[3:4]))


def test_an_observation_seen_again_gives_its_estimate_again():
    steps = _drive(2, 3)
    tracker = PoseTracker(MapLocalizer(WALLS, ROBOT), 2)
    first = [tracker(o, s) for o, s, _ in steps[:2]]
    correction = tracker.correction.copy()
    # the update asks for the state the policy acted on, then the one reached
    assert np.array_equal(tracker(*steps[0][:2]), first[0])
    assert np.array_equal(tracker(*steps[1][:2]), first[1])
    assert np.array_equal(tracker.correction, correction)
    tracker.begin_trial(np.array([1]))
    assert np.array_equal(tracker.correction[1], np.zeros(3))


def test_a_robot_with_beam_cones_is_localised_from_its_cone_readings():
    """Sonars with a 20 degree cone read the nearest of 5 sub-rays (the physics' model): the
    localiser models the same and corrects a drifted odometry."""
    robot = RobotConfig(sonar_cone_deg=20.0, sonar_cone_rays=5)
    physics = RobotBatch(WORLD, robot, 1, noise=False)
    true = np.array([[1.3, -0.7, 0.6]])
    r = physics.reset(np.arange(1), true, [np.random.default_rng(0)])
    odometry = true + np.array([[0.1, -0.08, 0.04]])
    cone = MapLocalizer(WALLS, robot)(odometry, r.sonar)
    thin = MapLocalizer(WALLS, ROBOT)(odometry, r.sonar)
    assert math.dist(cone[0, :2], true[0, :2]) < 0.005
    assert math.dist(cone[0, :2], true[0, :2]) < math.dist(thin[0, :2], true[0, :2])
