"""The goal re-found from the arrival scans: echoes joined per wall, the arrival point found in
a drifted odometry frame, nothing changed until the belief has passed through its goal."""

from __future__ import annotations

import math

import numpy as np
import pytest
from learner_helpers import whole_and_resumed

from symrl.knowledge.scan_odometry import (
    GOOD,
    echo_matcher,
    echo_segments,
    explained_share,
    relative_pose,
)
from symrl.learner.goal_scans import BESIDE_STEPS, MATCH_ITERATIONS, GoalScans
from symrl.world import load_map
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig

ROBOT = RobotConfig()
WORLD = load_map("hailu2001")
WALLS = Walls(WORLD.segments)
GOAL = (WORLD.goal.x, WORLD.goal.y)
N = ROBOT.n_sensors


def scan(pose: tuple[float, float, float]) -> np.ndarray:
    """Noise-free rim readings over the range (N,) at a true ``pose`` of the paper's world."""
    x, y, h = pose
    angles = h + np.arange(N) * (2 * math.pi / N)
    rays = WALLS.cast_many(
        np.array([x]), np.array([y]), angles[None], ROBOT.radius + ROBOT.sonar_range
    )[0]
    return np.clip(rays - ROBOT.radius, 0.0, ROBOT.sonar_range) / ROBOT.sonar_range


def scans(
    memory: int = 5, batch: int = 1, passing_by: bool = False, within_drift: bool = False
) -> GoalScans:
    return GoalScans(
        batch,
        goal=GOAL,
        goal_radius=WORLD.goal.radius,
        robot=ROBOT,
        memory=memory,
        passing_by=passing_by,
        within_drift=within_drift,
    )


ARRIVAL = (GOAL[0] + 0.2, GOAL[1] + 0.3, -1.5)  # on the goal's disc, driving south


def test_echoes_on_one_wall_are_joined_and_a_gap_is_not():
    readings = np.ones(N)
    readings[[0, 1, 2]] = 0.2  # three echoes 1 m ahead and to the left
    readings[12] = 0.2  # one echo behind, alone
    segments = echo_segments(ROBOT, readings)
    assert len(segments) == 2  # 0-1 and 1-2: a lone echo makes no segment
    ahead = segments[0][0]
    assert ahead == pytest.approx([1.0 + ROBOT.radius, 0.0])


@pytest.mark.parametrize("drift", [(0.6, -0.3), (-0.5, 0.4)])
def test_the_arrival_point_is_found_in_a_drifted_odometry_frame(drift):
    """A trial arrived at ARRIVAL with its odometry on the true pose; a later one, whose
    odometry is ``drift`` off, has driven through its believed goal and off it again: it aims
    at the arrival point in its own odometry frame (where steering takes it to ARRIVAL)."""
    goal_scans = scans()
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    true = np.array([GOAL[0] + 0.6, GOAL[1] + 1.1, -1.3])  # up the corridor
    shift = np.array([*drift, 0.0])
    options_aim = np.array([GOAL])
    on_goal = np.array([[GOAL[0], GOAL[1], 0.0]])
    off_goal = (true + shift)[None]
    assert goal_scans.aim(on_goal, options_aim, scan(tuple(on_goal[0])[:3])[None]) is options_aim
    assert goal_scans.summary(0) == {"goal_passed": 0, "goal_refound": 0}
    aim = goal_scans.aim(off_goal, options_aim, scan(tuple(true))[None])
    assert aim[0] == pytest.approx(np.array(ARRIVAL[:2]) + drift, abs=0.03)
    assert goal_scans.summary(0) == {"goal_passed": 1, "goal_refound": 1}


def test_nothing_changes_before_the_belief_has_passed_through_its_goal():
    goal_scans = scans()
    options_aim = np.array([GOAL])
    far = np.array([[GOAL[0] - 2.0, GOAL[1], 0.0]])
    readings = scan((GOAL[0] - 1.0, GOAL[1], 0.0))[None]
    # no arrival kept yet: even passing through the goal leaves the aim
    for pose in (GOAL[0], GOAL[1], 0.0), tuple(far[0]):
        assert goal_scans.aim(np.array([pose]), options_aim, readings) is options_aim
    goal_scans.begin_trial(np.array([0]))
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    assert goal_scans.aim(far, options_aim, readings) is options_aim  # not on the disc yet
    goal_scans.aim(np.array([[GOAL[0], GOAL[1], 0.0]]), options_aim, readings)
    assert goal_scans.aim(far, options_aim, readings) is not options_aim  # passed through
    goal_scans.begin_trial(np.array([0]))  # a new trial trusts its belief again
    assert goal_scans.aim(far, options_aim, readings) is options_aim


BESIDE = [(5.2, -2.0), (5.2, -3.0)]
"""A drive down the corridor whose belief (SHIFT off) runs 0.6 m beside the goal, then 1.2 m."""
APPROACH = [(5.0, -1.5)]
"""A drive whose belief comes 0.64 m from the goal: not on its disc, and no pass beside it."""


def _drive(goal_scans: GoalScans, warm_up: int, route: list[tuple[float, float]]) -> np.ndarray:
    """A trial whose odometry is SHIFT off drives down the corridor (true positions ``route``,
    heading south) after ``warm_up`` actions far up it: the aim at the end."""
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    goal_scans.begin_trial(np.array([0]))
    options_aim = np.array([GOAL])
    for x, y in [(5.2, 1.5)] * warm_up + route:
        true = (x, y, -math.pi / 2)
        belief = np.array([[true[0] + SHIFT[0], y + SHIFT[1], true[2]]])
        aim = goal_scans.aim(belief, options_aim, scan(true)[None])
    return aim


SHIFT = (-0.6, 0.0)  # the belief 0.6 m west of the truth: the goal found 0.72 m off the believed


@pytest.mark.parametrize("on", [False, True])
@pytest.mark.parametrize(
    ("setting", "route", "warm_up"),
    [("passing_by", BESIDE, 40), ("within_drift", APPROACH, 60)],  # 0.5 m / 0.94 m of drift
)
def test_a_drifted_belief_steers_at_the_goal_found_only_with_its_setting(
    setting, route, warm_up, on
):
    """Passing beside the believed goal, or coming within the drift of it, the belief never
    enters its disc: only the setting makes it search, and the goal found is steered at."""
    goal_scans = scans(**{setting: on})
    aim = _drive(goal_scans, warm_up, route)
    if on:
        assert aim[0] == pytest.approx(np.array(ARRIVAL[:2]) + SHIFT, abs=0.05)
        assert goal_scans.summary(0) == {"goal_passed": 1, "goal_refound": 1}
    else:  # never on the believed disc: nothing changes
        assert aim[0] == pytest.approx(GOAL)
        assert goal_scans.summary(0) == {"goal_passed": 0, "goal_refound": 0}


def test_a_goal_found_beside_it_farther_than_the_odometry_can_have_drifted_is_not_taken():
    goal_scans = scans(passing_by=True)
    aim = _drive(goal_scans, 0, BESIDE)  # 2 actions: the 0.72 m cannot be drift
    assert aim[0] == pytest.approx(GOAL)
    assert goal_scans.summary(0) == {"goal_passed": 0, "goal_refound": 0}


def test_a_search_from_beside_lasts_its_steps_after_each_pass():
    goal_scans = scans(passing_by=True)
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    options_aim = np.array([GOAL])
    room = scan((-1.0, 1.0, 0.0))[None]  # a scan no arrival explains
    true = (5.2, -3.0, -math.pi / 2)
    belief = np.array([[true[0] + SHIFT[0], true[1], true[2]]])
    near = np.array([[GOAL[0] + 0.6, GOAL[1], 0.0]])  # inside the widened disc
    for _ in range(40):  # the drift the goal found needs
        goal_scans.aim(belief + [0.0, 5.0, 0.0], options_aim, room)
    goal_scans.aim(near, options_aim, room)
    for _ in range(BESIDE_STEPS):  # passed: it searches, but finds nothing in the room scan
        goal_scans.aim(belief, options_aim, room)
    aim = goal_scans.aim(belief, options_aim, scan(true)[None])  # matchable, but too late
    assert aim[0] == pytest.approx(GOAL)
    goal_scans.aim(near, options_aim, room)  # a second pass searches again
    aim = goal_scans.aim(belief, options_aim, scan(true)[None])
    assert aim[0] == pytest.approx(np.array(ARRIVAL[:2]) + SHIFT, abs=0.05)


def test_no_search_within_the_drift_before_the_drift_exceeds_the_goals_radius():
    """After 20 actions the odometry can be 0.18 m off: the real goal is still on the believed
    disc, and the belief 0.64 m off it does not search."""
    goal_scans = scans(within_drift=True)
    aim = _drive(goal_scans, 20, APPROACH)
    assert aim[0] == pytest.approx(GOAL)
    assert not goal_scans.approached[0]


def test_the_drift_bound_grows_with_the_actions_as_the_heading_error_integrates():
    goal_scans = scans()
    bound = goal_scans.drift(np.array([0, 25, 100]))
    assert bound[0] == 0.0 and 0.2 < bound[1] < 0.3 and 1.9 < bound[2] < 2.1
    noiseless = GoalScans(
        1, goal=GOAL, goal_radius=0.4, robot=RobotConfig(translation_noise=0, rotation_noise_deg=0)
    )
    assert float(noiseless.drift(100)) == 0.0


def test_passing_by_farther_than_the_body_and_clearance_is_no_pass():
    goal_scans = scans(passing_by=True)
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    body = ROBOT.radius + ROBOT.close_distance
    wide = WORLD.goal.radius + 1.2 * body
    for dx in (-2.0, 0.0, 2.0):
        goal_scans.aim(np.array([[GOAL[0] + dx, GOAL[1] + wide, 0.0]]), np.array([GOAL]), None)
    assert goal_scans.summary(0)["goal_passed"] == 0


def _one_match(arrivals: list[tuple[float, float, float]], pose: np.ndarray, readings: np.ndarray):
    """The goal point one robot finds matching ``readings`` at odometry ``pose`` against each
    arrival alone (its own matcher on that arrival's echoes), the best share winning."""
    best, best_share = None, GOOD
    for arrival in arrivals:
        matcher = echo_matcher(ROBOT, scan(arrival), MATCH_ITERATIONS)
        assert matcher is not None
        estimate = matcher(relative_pose(np.array(arrival), pose)[None], readings[None])[0]
        share = explained_share(matcher, estimate, readings)
        if share >= best_share:
            x, y, h = estimate  # the arrival frame's origin, seen from the robot at ``pose``
            c, s = math.cos(h), math.sin(h)
            lx, ly = -(c * x + s * y), s * x - c * y
            cp, sp = math.cos(pose[2]), math.sin(pose[2])
            best = np.array([pose[0] + cp * lx - sp * ly, pose[1] + sp * lx + cp * ly])
            best_share = share
    return best


def test_robots_searching_in_one_batch_each_find_what_they_find_alone():
    """Three robots that drove through their believed goal search in one step: one with two
    arrivals kept (its odometry 0.6 m off), one with one (off the other way), one in the room
    whose scan no arrival explains. Matched together, each finds bitwise the point it finds matched
    against each arrival alone; a fault that mixed the robots' arrivals would not."""
    second = (GOAL[0] - 0.2, GOAL[1] + 0.1, 1.6)  # on the disc, driving north
    kept = [[second, ARRIVAL], [ARRIVAL], [ARRIVAL]]
    up_the_corridor = (GOAL[0] + 0.6, GOAL[1] + 1.1, -1.3)
    true = [up_the_corridor, (GOAL[0] + 0.3, GOAL[1] + 1.4, -1.6), (-2.0, 1.0, 0.0)]
    shift = [(0.5, -0.3, 0.0), (-0.5, 0.4, 0.0), (0.0, 0.0, 0.0)]
    batch = scans(batch=3)
    for row, arrivals in enumerate(kept):
        for arrival in arrivals:
            batch.learn(row, np.array(arrival), scan(arrival))
    options_aim = np.tile(GOAL, (3, 1))
    batch.aim(np.tile([GOAL[0], GOAL[1], 0.0], (3, 1)), options_aim, None)  # on the disc
    pose = np.array(true) + np.array(shift)
    readings = np.stack([scan(t) for t in true])
    aim = batch.aim(pose, options_aim, readings)
    for row in range(3):
        alone = _one_match(kept[row], pose[row], readings[row])
        if alone is None:
            assert aim[row].tolist() == list(GOAL)
        else:
            assert aim[row].tolist() == alone.tolist()
    assert aim[0] == pytest.approx(np.array(ARRIVAL[:2]) + shift[0][:2], abs=0.05)
    assert aim[1] == pytest.approx(np.array(ARRIVAL[:2]) + shift[1][:2], abs=0.05)
    assert aim[2].tolist() == list(GOAL)


def test_a_scan_the_arrivals_do_not_explain_keeps_the_aim():
    goal_scans = scans()
    goal_scans.learn(0, np.array(ARRIVAL), scan(ARRIVAL))
    options_aim = np.array([GOAL])
    goal_scans.aim(np.array([[GOAL[0], GOAL[1], 0.0]]), options_aim, None)
    # the robot in the room, far from any arrival: its scan explains nothing
    room = (-2.0, 1.0, 0.0)
    aim = goal_scans.aim(np.array([[0.0, 0.0, 0.0]]), options_aim, scan(room)[None])
    assert aim[0] == pytest.approx(GOAL)


def test_the_newest_arrivals_are_kept():
    goal_scans = scans(memory=2)
    for k in range(3):
        goal_scans.learn(0, np.array([float(k), 0.0, 0.0]), np.full(N, 0.1 * (k + 1)))
    a = goal_scans.arrays
    assert int(a["count"][0]) == 3
    assert a["poses"][0, :, 0].tolist() == [2.0, 1.0]  # the third replaced the first
    with pytest.raises(ValueError, match="memory"):
        scans(memory=0)


def test_a_run_that_re_finds_its_goal_resumes_as_if_uninterrupted(tmp_path) -> None:
    """The arrival scans are saved per robot with the controller: on this world and seed the
    third trial's belief passes through its goal and an arrival of trials 1-2 gives the goal."""
    # the raw odometry drifts enough here for the belief to pass its goal (scan odometry off)
    args = [
        "--seed",
        "5000",
        "--map",
        "tuning/pillar_grid",
        "options.wall_follow=false",
        "scan_odometry.enabled=false",
    ]
    a, b = whole_and_resumed(tmp_path, args, trials=4, stop=2)
    assert [(r["goal_passed"], r["goal_refound"]) for r in a][2] == (1, 1)
    assert a == b
