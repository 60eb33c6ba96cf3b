"""The odometry corrected by the robot's own scans: a drifted heading pulled back by the walls a
kept scan saw, the odometry kept where the scans say nothing, the same belief alone, in a batch
and when an observation is perceived again."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_localize import scan as localize_scan

from symrl.knowledge.localize import MapLocalizer
from symrl.knowledge.scan_odometry import (
    GOOD,
    MIN_RAYS,
    ScanOdometry,
    echo_matcher,
    explained_share,
    explained_shares,
    relative_pose,
)
from symrl.learner.config import ConfigError, RunConfig, load_config
from symrl.world import load_map
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig

ROBOT = RobotConfig()
WORLD = load_map("hailu2001")
WALLS = Walls(WORLD.segments)
START = np.array([WORLD.start.x, WORLD.start.y, WORLD.start.heading])


def scan(pose: np.ndarray) -> np.ndarray:
    """Noise-free readings over the range (n,) at a true ``pose`` of the paper's world."""
    return localize_scan(WALLS, pose[None])[0]


def drive(true: np.ndarray, odometry_error: np.ndarray, actions: int) -> list[np.ndarray]:
    """``actions`` + 1 true poses 0.2 m apart straight ahead from ``true``, each with the
    odometry ``odometry_error`` (3,) times the action's number off (a steady drift)."""
    poses = []
    for k in range(actions + 1):
        at = true + np.array([0.2 * k * math.cos(true[2]), 0.2 * k * math.sin(true[2]), 0.0])
        poses.append(at)
    return [p + k * odometry_error for k, p in enumerate(poses)]


def drifting_drive() -> tuple[list[np.ndarray], list[np.ndarray]]:
    """1.6 m straight across the paper's world's start room (9 poses) and an odometry whose
    heading drifts by a degree an action (twice the motion model's spread), its position
    integrating that heading as the wheels would."""
    true = drive(START, np.zeros(3), 8)
    drift = np.array([0.0, 0.0, math.radians(1.0)])
    odometry = [t + k * drift for k, t in enumerate(true)]
    for k in range(1, len(odometry)):
        h = odometry[k - 1][2]
        odometry[k][:2] = odometry[k - 1][:2] + 0.2 * np.array([math.cos(h), math.sin(h)])
    return true, odometry


def beliefs(tracker: ScanOdometry, true: list[np.ndarray], odometry: list[np.ndarray]):
    return [
        tracker(o[None].astype(np.float32), scan(t)[None])[0]
        for t, o in zip(true, odometry, strict=True)
    ]


def test_a_trials_first_observation_is_believed_as_the_odometry_gives_it():
    tracker = ScanOdometry(ROBOT, 1)
    belief = tracker(START[None].astype(np.float32), scan(START)[None])
    assert belief[0] == pytest.approx(START, abs=1e-6)


def test_a_drifting_heading_is_pulled_back_by_the_walls_the_kept_scan_saw():
    """The odometry's heading drifts by a degree an action (twice the motion model's spread)
    while the robot drives 1.6 m across the paper's world's start room: the odometry ends a
    decimetre and 8 degrees off, the belief (measured: 1.5 cm, 0.3 degrees) under half that."""
    true, odometry = drifting_drive()
    tracker = ScanOdometry(ROBOT, 1, keyframe_actions=3)
    believed = beliefs(tracker, true, odometry)
    odometry_off = math.dist(odometry[-1][:2], true[-1][:2])
    belief_off = math.dist(believed[-1][:2], true[-1][:2])
    assert odometry_off > 0.08
    assert belief_off < 0.5 * odometry_off
    assert abs(believed[-1][2] - true[-1][2]) < 0.5 * abs(odometry[-1][2] - true[-1][2])


def test_readings_beyond_the_outlier_gate_are_left_out_of_the_match():
    """The drifting drive above: with a gate no reading passes (1 micrometre) the match has
    nothing but its prior, the odometry's increment, and the belief ends where the odometry
    does; with a gate of 7.5 cm, which passes the readings a drift of a few degrees moves, the
    walls pull the heading back as with the default."""
    true, odometry = drifting_drive()
    shut = beliefs(ScanOdometry(ROBOT, 1, keyframe_actions=3, outlier=1e-6), true, odometry)
    assert shut[-1] == pytest.approx(odometry[-1], abs=1e-4)
    gated = beliefs(ScanOdometry(ROBOT, 1, keyframe_actions=3, outlier=0.075), true, odometry)
    assert abs(gated[-1][2] - true[-1][2]) < 0.5 * abs(odometry[-1][2] - true[-1][2])


def test_without_echoes_the_odometry_stands():
    """Nothing within range: no match, every observation believed as the odometry gives it."""
    tracker = ScanOdometry(ROBOT, 1)
    for k in range(7):
        pose = np.array([[1.0 + 0.2 * k, 2.0, 0.1 * k]], dtype=np.float32)
        belief = tracker(pose, np.ones((1, ROBOT.n_sensors)))
        assert belief[0] == pytest.approx(pose[0].astype(np.float64), abs=1e-6)


def test_a_robot_believes_the_same_alone_and_in_a_batch():
    true = drive(START, np.zeros(3), 6)
    odometry = drive(START, np.array([0.01, -0.005, 0.01]), 6)
    other = drive(START + np.array([0.3, 0.5, 0.4]), np.array([0.0, 0.01, -0.01]), 6)
    alone = beliefs(ScanOdometry(ROBOT, 1), true, odometry)
    batch = ScanOdometry(ROBOT, 2)
    for k, (t, o) in enumerate(zip(true, odometry, strict=True)):
        odo = np.stack((other[k], o)).astype(np.float32)
        belief = batch(odo, np.stack((scan(other[k]), scan(t))))
        assert np.array_equal(belief[1], alone[k])


def test_robots_at_different_keyframes_in_one_batch_believe_as_each_alone():
    """Three robots fitted in one call, each against its own keyframe: one a few actions into
    its trial when another starts (their keyframes renew at different steps), one with no echo
    in range (its odometry stands); each robot's beliefs are bitwise its beliefs alone."""
    true = drive(START, np.zeros(3), 14)
    odometry = drive(START, np.array([0.01, -0.005, 0.01]), 14)
    late = drive(START + np.array([0.3, 0.5, 0.4]), np.array([0.0, 0.01, -0.01]), 11)
    blind = drive(START, np.array([0.02, 0.0, 0.0]), 14)
    alone = beliefs(ScanOdometry(ROBOT, 1), true, odometry)
    alone_late = beliefs(ScanOdometry(ROBOT, 1), late, late)
    batch = ScanOdometry(ROBOT, 3)
    for k in range(15):
        j = max(k - 3, 0)  # the late robot's trial starts at the batch's fourth observation
        if k == 3:
            batch.begin_trial(np.array([1]))
        odo = np.stack((odometry[k], late[j], blind[k])).astype(np.float32)
        sonar = np.stack((scan(true[k]), scan(late[j]), np.ones(ROBOT.n_sensors)))
        belief = batch(odo, sonar)
        assert np.array_equal(belief[0], alone[k])
        if k >= 3:
            assert np.array_equal(belief[1], alone_late[j])
        np.testing.assert_allclose(belief[2], odo[2], atol=1e-9)


def test_an_observation_seen_again_gives_its_estimate_again():
    """The policy and the update perceive the same observation in turn: the second time
    returns the first's belief and does not move the keyframe on."""
    true = drive(START, np.zeros(3), 4)
    odometry = drive(START, np.array([0.01, 0.0, 0.01]), 4)
    once = beliefs(ScanOdometry(ROBOT, 1), true, odometry)
    tracker = ScanOdometry(ROBOT, 1)
    twice = []
    for t, o in zip(true, odometry, strict=True):
        first = tracker(o[None].astype(np.float32), scan(t)[None])[0]
        again = tracker(o[None].astype(np.float32), scan(t)[None])[0]
        assert np.array_equal(first, again)
        twice.append(first)
    assert all(np.array_equal(a, b) for a, b in zip(once, twice, strict=True))


def test_a_new_trial_starts_on_its_odometry_again():
    true = drive(START, np.zeros(3), 4)
    odometry = drive(START, np.array([0.02, 0.0, 0.02]), 4)
    tracker = ScanOdometry(ROBOT, 1)
    beliefs(tracker, true, odometry)
    tracker.begin_trial(np.array([0]))
    belief = tracker(START[None].astype(np.float32), scan(START)[None])
    assert belief[0] == pytest.approx(START, abs=1e-6)


def test_a_match_with_its_own_prior_equals_a_localizer_built_with_that_prior():
    """The per-call prior (the odometry's drift since the keyframe) is the localiser's own."""
    pose = START + np.array([0.05, -0.04, 0.03])
    readings = scan(START)[None]
    spread_xy, spread_heading = 0.07, 0.02
    built = MapLocalizer(WALLS, ROBOT, 4, spread_xy, spread_heading)
    general = MapLocalizer(WALLS, ROBOT, 4, 1.0, 1.0)
    prior = np.diag([spread_xy**-2, spread_xy**-2, spread_heading**-2])
    assert np.array_equal(general(pose[None], readings, prior=prior), built(pose[None], readings))


def test_relative_pose_is_the_pose_in_the_frames_own_axes():
    frame = np.array([1.0, 2.0, math.pi / 2])
    assert relative_pose(frame, np.array([1.0, 3.0, math.pi])) == pytest.approx(
        [1.0, 0.0, math.pi / 2]
    )


@pytest.mark.parametrize("key", ["keyframe_actions", "iterations", "outlier"])
def test_bad_settings_are_named(key):
    with pytest.raises(ValueError, match=key):
        RunConfig.model_validate({"scan_odometry": {key: 0}})
    with pytest.raises(ValueError, match="keyframe_actions"):
        ScanOdometry(ROBOT, 1, keyframe_actions=0)
    with pytest.raises(ValueError, match="outlier must be > 0, got -1"):
        ScanOdometry(ROBOT, 1, outlier=-1)


def test_a_finished_trials_record_holds_how_far_the_scans_moved_the_belief():
    """At the next trial's start the last observation's belief-to-odometry distance is kept for
    the finished trial's record; before any trial it is 0."""
    true = drive(START, np.zeros(3), 8)
    odometry = drive(START, np.array([0.0, 0.01, 0.0]), 8)  # drifting north 1 cm an action
    tracker = ScanOdometry(ROBOT, 1)
    assert tracker.summary(0) == {"scan_correction_m": 0.0}
    believed = beliefs(tracker, true, odometry)
    tracker.begin_trial(np.array([0]))
    moved = math.dist(believed[-1][:2], odometry[-1][:2])
    assert tracker.summary(0)["scan_correction_m"] == pytest.approx(moved, abs=1e-5)
    assert 0.04 < moved < 0.12  # most of the 8 cm the odometry drifted


def test_a_config_with_both_pose_sources_is_one_line_refused():
    with pytest.raises(ConfigError, match="scan_odometry.enabled=true and localize.enabled=true"):
        load_config("paper_map", ["scan_odometry.enabled=true"])


def test_the_explained_share_of_a_scan_against_a_kept_ones_echoes():
    """The paper's start scan kept; 0.1 m further ahead, a new scan at its true pose relative
    to the kept one is explained ray for ray (share 1), and 0.3 m off it, under GOOD (most rays
    miss by more than NEAR). At the kept pose itself every ray ends on a segment's end, which
    the matcher does not judge (share 0, too few rays); nor with fewer than MIN_RAYS echoes.
    The batched shares are the single ones row by row."""
    kept = scan(START)
    matcher = echo_matcher(ROBOT, kept, 4)
    assert matcher is not None
    true = START + np.array([0.1 * math.cos(START[2]), 0.1 * math.sin(START[2]), 0.0])
    later = scan(true)
    at, off = relative_pose(START, true), relative_pose(START, true) + np.array([0.3, 0, 0])
    assert explained_share(matcher, at, later) == 1.0
    assert explained_share(matcher, off, later) < GOOD
    assert explained_share(matcher, np.zeros(3), kept) == 0.0
    few = np.ones(ROBOT.n_sensors)
    few[: MIN_RAYS - 1] = later[: MIN_RAYS - 1]
    assert explained_share(matcher, at, few) == 0.0
    shares = explained_shares(matcher, np.stack((at, off)), np.stack((later, later)))
    assert shares.tolist() == [
        explained_share(matcher, at, later),
        explained_share(matcher, off, later),
    ]
