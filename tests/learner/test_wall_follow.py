"""Out of a trap by its wall: a robot on its way is left alone; one circling in a cup follows the
nearest wall on the side nearer its aim, and leaves it in another region or nearer its aim with
the way clear."""

from __future__ import annotations

import math

import numpy as np
from learner_helpers import paper_trials, whole_and_resumed

from symrl.learner.wall_follow import WINDOW, WallFollow
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig

ROBOT = RobotConfig()
N = ROBOT.n_sensors
# a cup 2 m wide open to the south, its closed top at y = 4.5, in a 10 m x 8 m room
CUP = np.array(
    [
        [[4.0, 2.0], [4.0, 4.5]],
        [[6.0, 2.0], [6.0, 4.5]],
        [[4.0, 4.5], [6.0, 4.5]],
        [[0.0, 0.0], [10.0, 0.0]],
        [[10.0, 0.0], [10.0, 8.0]],
        [[10.0, 8.0], [0.0, 8.0]],
        [[0.0, 8.0], [0.0, 0.0]],
    ]
)
WALLS = Walls(CUP)
AIM = np.array([[3.6, 4.9]])  # beyond the cup's top west corner


def scan(pose: np.ndarray) -> np.ndarray:
    """Noise-free readings over the range (1, N) at ``pose`` (3,) in the cup world."""
    angles = pose[2] + np.arange(N) * (2 * math.pi / N)
    rays = WALLS.cast_many(
        np.array([pose[0]]), np.array([pose[1]]), angles[None], ROBOT.radius + ROBOT.sonar_range
    )
    return np.clip(rays - ROBOT.radius, 0.0, ROBOT.sonar_range) / ROBOT.sonar_range


def circle(follow: WallFollow, steps: int) -> np.ndarray:
    """Drive ``steps`` actions round a 0.3 m circle under the cup's top; the last aim (1, 2)."""
    out = AIM
    for k in range(steps):
        a = k * 0.7
        pose = np.array([[5.0 + 0.3 * math.cos(a), 3.9 + 0.3 * math.sin(a), a + math.pi / 2]])
        out = follow.aim(pose, AIM, scan(pose[0]))
    return out


def test_a_robot_on_its_way_is_left_alone() -> None:
    follow = WallFollow(1, ROBOT)
    for k in range(2 * WINDOW):
        pose = np.array([[1.0 + 0.1 * k, 1.0, 0.0]])
        assert np.array_equal(follow.aim(pose, AIM, scan(pose[0])), AIM)
    assert not follow.following[0]
    assert follow.summary(0) == {"wall_follows": 0}


def test_a_circling_robot_follows_the_nearest_wall_on_its_aims_side() -> None:
    follow = WallFollow(1, ROBOT)
    before = circle(follow, WINDOW - 1)
    assert np.array_equal(before, AIM) and not follow.following[0]
    pose = np.array([5.0, 4.0, 0.0])  # 0.5 m under the top: the top is the nearest wall
    out = follow.aim(pose[None], AIM, scan(pose))
    assert follow.following[0] and follow.summary(0) == {"wall_follows": 1}
    step = out[0] - pose[:2]
    assert math.isclose(float(np.hypot(*step)), 1.0)
    # along the top, westward (the aim's side), turned 0.1 rad away from it (0.5 m < 0.6 m)
    assert step[0] < -0.99 and step[1] < 0.0
    assert math.isclose(math.atan2(step[1], step[0]), -math.pi + 0.1, abs_tol=1e-9)


def test_the_follow_rounds_an_inner_corner_away_from_the_wall() -> None:
    follow = WallFollow(1, ROBOT)
    circle(follow, WINDOW)
    turned = None
    for x in np.arange(5.0, 4.25, -0.05):  # along the cup's top, westward, into its corner
        pose = np.array([x, 3.9, math.pi])
        out = follow.aim(pose[None], AIM, scan(pose))[0] - pose[:2]
        if out[1] < -0.5:  # the wall on its right: it turns left, down the cup's west side
            turned = x
            break
    assert turned is not None and turned > 4.0 + ROBOT.radius + 0.1


def test_trapped_again_in_the_same_place_it_takes_the_other_side() -> None:
    follow = WallFollow(1, ROBOT)
    circle(follow, WINDOW)
    outside = np.array([[3.6, 4.0, math.pi / 2]])
    follow.aim(outside, AIM, scan(outside[0]))  # out: nearer the aim, the way clear
    assert not follow.following[0]
    circle(follow, WINDOW - 1)
    pose = np.array([5.0, 4.0, 0.0])
    step = follow.aim(pose[None], AIM, scan(pose))[0] - pose[:2]
    assert follow.summary(0) == {"wall_follows": 2}
    assert step[0] > 0.99  # eastward now, the wall on its left


def test_the_follow_ends_nearer_the_aim_with_the_way_clear_and_not_before() -> None:
    follow = WallFollow(1, ROBOT)
    circle(follow, WINDOW)
    outside = np.array([[3.6, 4.0, math.pi / 2]])  # west of the cup, nearer, the way up clear
    farther = np.array([[5.0, 2.5, -math.pi / 2]])  # in the cup's mouth: farther than at start
    assert not np.array_equal(follow.aim(farther, AIM, scan(farther[0])), AIM)
    assert follow.following[0]
    assert np.array_equal(follow.aim(outside, AIM, scan(outside[0])), AIM)
    assert not follow.following[0]


def test_a_new_trial_forgets_the_trail() -> None:
    follow = WallFollow(1, ROBOT)
    circle(follow, WINDOW)
    follow.begin_trial(np.array([0]))
    assert not follow.following[0] and follow.summary(0) == {"wall_follows": 0}
    assert np.array_equal(circle(follow, WINDOW - 1), AIM)


def test_the_paper_robot_gets_out_of_a_u_the_rules_draw_no_line_around() -> None:
    """`tuning/u_wall`: the goal's bearing leads into a U open toward the start, in the goal's
    own region; without the follow the first trial circles in the U to the last action."""
    steps = {}
    for follow in (False, True):
        (trial,) = paper_trials("tuning/u_wall", 5000, 1, f"options.wall_follow={follow}")
        steps[follow] = (int(trial["steps"]), bool(trial["reached_goal"]))
        assert ("wall_follows" in trial) == follow
    assert steps[False] == (200, False)
    assert steps[True][1] and steps[True][0] < 150


def test_the_paper_robot_leaves_a_cup_whose_walls_hide_the_line_beyond_them() -> None:
    """`tuning/cup_start_east`: the robot starts in a cup open away from the goal, the one
    region line beyond its end wall. Seen only behind the cup's walls, that border is still its
    way on (the rules' graph has no other): aiming past the line beyond the cup's corners, it
    drives out of the mouth in its first trial, with the follow as without it."""
    for follow in (False, True):
        (trial,) = paper_trials("tuning/cup_start_east", 5000, 1, f"options.wall_follow={follow}")
        assert bool(trial["reached_goal"]) and int(trial["steps"]) < 150


def test_the_follow_rounds_a_door_post_out_of_the_room_the_robot_starts_in() -> None:
    """`tuning/room_start_back_door`: the robot starts in a room whose 1 m door is in its far
    wall. Without the follow none of its first three trials leaves the room; with it, a trial
    that followed the room's walls turns round the door's post and out, instead of taking up
    the wall beyond the door, and reaches the goal (a start room's first trial can still run
    out of actions before the trap check sees it trapped)."""
    for follow in (False, True):
        trials = paper_trials(
            "tuning/room_start_back_door", 6001, 3, f"options.wall_follow={follow}"
        )
        out = [bool(t["reached_goal"]) and t.get("wall_follows", 0) >= 1 for t in trials]
        assert any(out) == follow
        assert any(bool(t["reached_goal"]) for t in trials) == follow


def test_a_robot_follows_alike_alone_in_a_batch_and_resumed(tmp_path) -> None:
    """The follow's trail and side are per robot and per trial: seed 5000 on
    `tuning/cup_start_east` gives the same trials alone, beside another seed, and resumed."""
    from symrl.studies.runner import resolve_config
    from symrl.train import train_batch

    config = resolve_config("paper", ["env.map=tuning/cup_start_east", "run.trials=3"])
    alone = train_batch(config, [5000], progress=False)[0].trials
    beside = train_batch(config, [5001, 5000], progress=False)[1].trials
    key = [(t["steps"], round(t["total_reinforcement"], 6), t["wall_follows"]) for t in alone]
    assert key == [
        (t["steps"], round(t["total_reinforcement"], 6), t["wall_follows"]) for t in beside
    ]
    assert any(t["wall_follows"] for t in alone)
    whole, resumed = whole_and_resumed(
        tmp_path, ["--seed", "5000", "--map", "tuning/cup_start_east"], trials=3, stop=1
    )
    assert whole == resumed
