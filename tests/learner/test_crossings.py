"""The crossing map: sonar evidence along the region rules' borders at known poses, the
crossing chosen from it, crossings recorded from odometry, stretches given up, and the options
routing around a border found blocked. The walls are used here only to make the sonar readings
(the env's own noise-free ``sense``); the map itself never sees them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from learner_helpers import paper_trials

from symrl.knowledge.borders import Border, region_borders
from symrl.knowledge.rungs import Knowledge
from symrl.learner.config import CrossingsConfig, OptionCriticConfig, OptionsConfig, load_config
from symrl.learner.crossings import CrossingMap
from symrl.learner.options import SubgoalOptions
from symrl.world.env import Hailu2001Env
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import load_map

OFFICE = load_map("office")  # west door x in [1.5, 2.5] on y = 2.05 (offices line)
ROBOT = RobotConfig()
UNKNOWN, OPEN, BLOCKED = 0, 1, 2


def _map(borders, batch: int = 1, origin=(2.0, 4.5), dead_ends: bool = True) -> CrossingMap:
    return CrossingMap(
        borders,
        batch,
        radius=ROBOT.radius,
        close_distance=ROBOT.close_distance,
        sonar_range=ROBOT.sonar_range,
        n_sensors=ROBOT.n_sensors,
        origin=origin,
        reach=20.0,
        resolution=0.1,
        dead_ends=dead_ends,
    )


def _office_door() -> tuple[int, Border]:
    """The border between the west office and its door region: the offices line, x < 4."""
    for j, b in enumerate(region_borders(OFFICE.regions)):
        if {b.low, b.high} == {"west_office", "west_door"}:
            return j, b
    raise AssertionError("office has no west office border")


def _look(cmap: CrossingMap, poses) -> None:
    env = Hailu2001Env(OFFICE, noise=False)
    for x, y, h in poses:
        rim, _ = env.sense(x, y, h)
        cmap.observe(np.array([[x, y, h]]), rim[None, :].astype(np.float64))


def test_rays_show_the_door_open_and_the_wall_beside_it_blocked():
    j, border = _office_door()
    cmap = _map(region_borders(OFFICE.regions))
    _look(cmap, [(2.0, 3.0, -math.pi / 2), (1.0, 3.2, -math.pi / 2), (3.2, 3.0, -math.pi / 2)])
    centres, state = cmap.seen(0, j)
    door = (centres > 1.6) & (centres < 2.4)
    walls = ((centres > 0.3) & (centres < 1.3)) | ((centres > 2.7) & (centres < 3.8))
    seen_door = state[door][state[door] != UNKNOWN]
    seen_wall = state[walls][state[walls] != UNKNOWN]
    assert len(seen_door) > 3 and (seen_door == OPEN).all()
    assert len(seen_wall) > 5 and (seen_wall == BLOCKED).all()


def test_the_crossing_is_the_middle_of_the_door_seen_open():
    j, border = _office_door()
    cmap = _map(region_borders(OFFICE.regions))
    _look(cmap, [(2.0, 3.0, -math.pi / 2), (1.0, 3.2, -math.pi / 2), (3.2, 3.0, -math.pi / 2)])
    # the goal lies east: the fixed rule point would be at x = 3.5, on the wall
    found = cmap.crossing(0, j, np.array([2.0, 3.0]), (10.0, 4.5))
    assert found is not None
    t, first, last = found
    assert 1.8 < t < 2.2  # the door (1 m) is narrower than two insets: its middle
    assert 1.3 < cmap.lo[j] + first * 0.1 <= 1.6 and 2.4 <= cmap.lo[j] + (last + 1) * 0.1 < 2.7


def test_with_no_evidence_the_crossing_is_nearest_the_goal():
    border = Border("l", 0, 1.0, -10.0, 10.0, "a", "b")
    cmap = _map([border], origin=(0.0, 0.0))
    t, _, _ = cmap.crossing(0, 0, np.array([0.0, 0.0]), (3.0, 2.0))
    assert t == pytest.approx(2.0, abs=0.06)


def test_a_border_seen_blocked_everywhere_has_no_crossing():
    border = Border("l", 0, 1.0, -1.0, 1.0, "a", "b")
    cmap = _map([border], origin=(0.0, 0.0))
    cmap.arrays["blocked"][0, 0, :] = 3.0
    assert cmap.crossing(0, 0, np.array([0.0, 0.0]), (3.0, 0.0)) is None
    cmap.arrays["open"][0, 0, 5:12] = 4.0  # 0.7 m seen open: wider than the body
    assert cmap.crossing(0, 0, np.array([0.0, 0.0]), (3.0, 0.0)) is not None


def test_a_gap_narrower_than_the_body_is_no_crossing():
    border = Border("l", 0, 1.0, -1.0, 1.0, "a", "b")
    cmap = _map([border], origin=(0.0, 0.0))
    cmap.arrays["blocked"][0, 0, :] = 3.0
    cmap.arrays["open"][0, 0, 8:12] = 4.0  # 0.4 m < 2 x 0.26 m
    assert cmap.crossing(0, 0, np.array([0.0, 0.0]), (3.0, 0.0)) is None


def test_a_crossing_from_odometry_opens_a_body_width_and_only_that_robots():
    border = Border("l", 0, 1.0, -5.0, 5.0, "a", "b")
    cmap = _map([border], batch=2, origin=(0.0, 0.0))
    cmap.cross(1, "a", "b", np.array([0.9, 0.3]), np.array([1.1, 0.5]))
    centres, state = cmap.seen(1, 0)
    opened = centres[state == OPEN]
    assert opened.min() == pytest.approx(0.4 - 0.26, abs=0.1)
    assert opened.max() == pytest.approx(0.4 + 0.26, abs=0.1)
    assert (cmap.seen(0, 0)[1] == UNKNOWN).all()
    cmap.cross(1, "a", "c", np.array([0.9, 3.0]), np.array([1.1, 3.0]))  # not this border
    assert (cmap.seen(1, 0)[1][np.abs(centres - 3.0) < 0.5] == UNKNOWN).all()


def _two_doors(dead_ends: bool = True) -> CrossingMap:
    """A wall on x = 1 between regions a (west) and b (east), with doors at y in [-3, -2]
    (away from the goal) and [0, 1] (on its bearing), both seen open."""
    cmap = _map([Border("l", 0, 1.0, -5.0, 5.0, "a", "b")], origin=(0.0, 0.0), dead_ends=dead_ends)
    cmap.arrays["blocked"][0, 0, :] = 3.0
    for lo, hi in ((-3.0, -2.0), (0.0, 1.0)):
        cmap.arrays["open"][0, 0, int((lo + 5) / 0.1) : int((hi + 5) / 0.1)] = 4.0
    return cmap


FOLLOWING, GOAL, BORDER_0 = np.array([True]), np.array([-1]), np.array([0])


def _in_trapped_out(cmap: CrossingMap, aiming=GOAL, out_y: float = 0.4) -> None:
    """In by the door on the bearing, trapped beyond it aiming at ``aiming``, back out at
    ``out_y``."""
    cmap.cross(0, "a", "b", np.array([0.9, 0.5]), np.array([1.1, 0.5]))
    cmap.watch(FOLLOWING, aiming)
    cmap.cross(0, "b", "a", np.array([1.1, out_y]), np.array([0.9, out_y]))


def _aim(cmap: CrossingMap, xy=(0.0, 0.0), goal=(3.0, 0.5)) -> float:
    return cmap.crossing(0, 0, np.array(xy), goal)[0]


def test_a_door_crossed_into_a_trap_and_back_out_comes_last_that_way():
    cmap = _two_doors()
    assert _aim(cmap) == pytest.approx(0.5, abs=0.06)
    _in_trapped_out(cmap)
    assert -3.0 < _aim(cmap) < -2.0  # the other door, though farther
    assert _aim(cmap, (2.0, 0.5), (-3.0, 0.5)) == pytest.approx(0.5, abs=0.06)  # the other way
    cmap.arrays["blocked"][0, 0, 20:30] = 9.0  # the other door shut: the dead end is left
    assert _aim(cmap) == pytest.approx(0.5, abs=0.06)


def test_no_dead_end_without_a_trap_on_the_way_on_or_out_the_way_in():
    untrapped = _two_doors()
    untrapped.cross(0, "a", "b", np.array([0.9, 0.5]), np.array([1.1, 0.5]))
    untrapped.cross(0, "b", "a", np.array([1.1, 0.4]), np.array([0.9, 0.4]))
    aiming_back = _two_doors()  # trapped while its option led back across the door
    _in_trapped_out(aiming_back, aiming=BORDER_0)
    out_elsewhere = _two_doors()  # out by the other door
    _in_trapped_out(out_elsewhere, out_y=-2.5)
    marks_off = _two_doors(dead_ends=False)
    _in_trapped_out(marks_off)
    for cmap in (untrapped, aiming_back, out_elsewhere, marks_off):
        assert _aim(cmap) == pytest.approx(0.5, abs=0.06)


def test_a_new_trial_forgets_where_the_robot_came_in():
    cmap = _two_doors()
    cmap.cross(0, "a", "b", np.array([0.9, 0.5]), np.array([1.1, 0.5]))
    cmap.forget(np.array([0]))
    cmap.watch(FOLLOWING, GOAL)
    cmap.cross(0, "b", "a", np.array([1.1, 0.4]), np.array([0.9, 0.4]))
    assert _aim(cmap) == pytest.approx(0.5, abs=0.06)


def test_the_paper_robot_learns_that_the_door_on_the_goals_bearing_leads_into_a_closet():
    """`tuning/closet_first_door`: the door on the goal's bearing opens into a closet; the
    robot drives in, is trapped, follows the closet's wall out by the door, and marks it."""
    trials = {
        # the odometry of the run this scenario was read from (scan odometry off)
        marks: paper_trials(
            "tuning/closet_first_door",
            5000,
            3,
            f"crossings.dead_ends={marks}",
            "scan_odometry.enabled=false",
        )
        for marks in (False, True)
    }
    assert all("crossings_dead_end_m" not in t for t in trials[False])
    assert 0.5 < trials[True][0]["crossings_dead_end_m"] < 1.5  # the closet's 1 m door
    assert [int(t["steps"]) for t in trials[False]] == [200] * 3
    assert trials[True][2]["reached_goal"] and int(trials[True][2]["steps"]) < 80  # optimum 55


@settings(max_examples=40, deadline=None)
@given(x=st.floats(0.4, 3.6), y=st.floats(2.5, 5.6), heading=st.floats(-math.pi, math.pi))
def test_no_ray_from_the_west_office_shows_its_walls_open(x, y, heading):
    """Wherever the robot stands in the west office, the offices line is never shown open
    outside the door (a ray that passes the line went through the door)."""
    j, border = _office_door()
    cmap = _map(region_borders(OFFICE.regions))
    _look(cmap, [(x, y, heading)])
    centres, state = cmap.seen(0, j)
    opened = centres[state == OPEN]
    assert ((opened > 1.5 - 0.1) & (opened < 2.5 + 0.1)).all()


def test_the_crossing_map_is_built_from_the_rules_alone():
    config = load_config("paper", ["crossings.enabled=true"])
    told = Knowledge.told(OFFICE, "regions")
    assert told.world is None
    opts = SubgoalOptions(
        told, 1, config.options, [0], None, config.option_critic, config.crossings, ROBOT, 200
    )
    assert opts.crossings is not None
    assert len(opts.crossings.borders) == len(region_borders(OFFICE.regions))


def test_crossings_need_the_rules_options():
    with pytest.raises(ValueError, match="it needs options.source=rules, got options.source=map"):
        load_config("paper_map", ["crossings.enabled=true"])
    assert load_config("paper", ["options.enabled=false"]).crossings.enabled  # inert


def _options(world, **cfg) -> SubgoalOptions:
    """The options of one robot told ``world``'s region rules, with the crossing map."""
    told = Knowledge.told(world, "regions")
    config = OptionsConfig(enabled=True, source="rules")
    explore = OptionCriticConfig(epsilon=0.0, try_untried=False)
    return SubgoalOptions(
        told, 1, config, [0], None, explore, CrossingsConfig(enabled=True, **cfg), ROBOT, 200
    )


def _office_options(**cfg) -> SubgoalOptions:
    return _options(OFFICE, **cfg)


def _wc_border(opts: SubgoalOptions) -> int:
    """The border between the west and the middle office (the wall wc)."""
    return next(
        i
        for i, b in enumerate(opts.crossings.borders)
        if {b.low, b.high} == {"west_office", "middle_office"}
    )


def _labels(opts: SubgoalOptions, region: str) -> list[str]:
    r = opts.region_names.index(region)
    offered = opts._offered(0, r, opts.valid[r].tolist(), [False] * opts.valid.shape[1])
    return [label for label, ok in zip(opts.labels[r], offered, strict=False) if ok]


@pytest.mark.parametrize("seen", ["blocked", "hidden"])
def test_a_border_found_blocked_is_routed_around(seen):
    """The rules say the west office borders the middle office (through the wall between
    them, line wc); told so, the west door leads farther from the goal and is not offered.
    Once the robot finds the wc border blocked, or sees it only behind other walls along its
    whole length (the west door leaves another way to the goal), the region graph goes round
    by the door."""
    opts = _office_options()
    assert _labels(opts, "west_office") == ["goal", "wc>middle_office"]
    opts.crossings.arrays[seen][0, _wc_border(opts), :] = 5.0
    opts.begin_trial(torch.tensor([0]))
    assert _labels(opts, "west_office") == ["goal", "offices>west_door"]


def _start_room_options() -> tuple[SubgoalOptions, int]:
    """``tuning/room_start_back_door``: the robot starts in a room whose walls hide the one
    region line (along the room's north wall, across the hall) beyond them."""
    opts = _options(load_map("tuning/room_start_back_door"))
    (j,) = range(len(opts.crossings.borders))
    return opts, j


@pytest.mark.parametrize("seen", ["hidden", "blocked"])
def test_the_last_way_on_seen_only_behind_other_walls_stays_a_way_on(seen):
    """The line's one border is the only way to the goal's region. Seen only behind the room's
    own walls (which may be passed round) it stays offered, and the robot aims past the line;
    seen blocked along its whole length (a wall on the line) it is found blocked."""
    opts, j = _start_room_options()
    opts.crossings.arrays[seen][0, j, :] = 5.0
    opts.begin_trial(torch.tensor([0]))
    assert _labels(opts, "south") == (["goal", "top>north"] if seen == "hidden" else ["goal"])
    r = opts.region_names.index("south")
    k = opts.labels[r].index("top>north")
    opts.arrays["choice"][0, r] = k
    _, option, _, aim, _ = opts.steer(torch.tensor([r]), torch.tensor([[4.6, 3.8, 1.57]]), False)
    if seen == "hidden":
        assert int(option[0]) == k
        assert aim[0, 1].item() == pytest.approx(4.8 + 0.4, abs=1e-6)  # past the line
    else:
        assert int(option[0]) != k
    # the trial records count it blocked as the options do
    record = opts.crossings.summary(0, hidden_too=opts.bridges)
    assert record["borders_blocked"] == (0 if seen == "hidden" else 1)


def _loop_scans(opts: SubgoalOptions, region: str | None) -> None:
    """``tuning/block_loop_north``: the robot's noise-free scans from the east end of the
    south corridor (the block hides the line between the north and the east corridor beyond
    it), observed as cast from ``region`` (None: the region not given)."""
    env = Hailu2001Env(load_map("tuning/block_loop_north"), noise=False)
    index = None if region is None else np.array([opts.region_names.index(region)])
    for x in (6.5, 7.0, 7.5):
        for h in np.linspace(-math.pi, math.pi, 8, endpoint=False):
            rim, _ = env.sense(x, 1.0, h)
            pose = np.array([[x, 1.0, h]])
            opts.crossings.observe(pose, rim[None, :].astype(np.float64), index)


def _north_east(opts: SubgoalOptions) -> int:
    return next(
        i for i, b in enumerate(opts.crossings.borders) if {b.low, b.high} == {"north", "east"}
    )


@pytest.mark.parametrize("region", ["south", "north"])
def test_a_border_hidden_from_a_third_region_stays_unseen(region):
    """Rays that meet the block before the north/east line say that line is hidden only when
    cast from one of its two regions: from the south corridor (a third region) the line stays
    unseen, so the north keeps its way on to the goal's region and the west corridor offers
    the short way round the north; cast from the north, something stands between that region
    and the line, and the region graph goes round the south."""
    opts = _options(load_map("tuning/block_loop_north"))
    _loop_scans(opts, region)
    hidden = opts.crossings.arrays["hidden"][0, _north_east(opts)]
    opts.begin_trial(torch.tensor([0]))
    if region == "south":
        assert not hidden.any()
        assert "left>north" in _labels(opts, "west")
    else:
        assert hidden.sum() > 1.0
        assert _labels(opts, "west") == ["goal", "left>south"]


def test_without_regions_every_stopped_ray_shows_its_border_hidden():
    """A map not told the regions the rays were cast from counts them all (as a robot that
    never leaves one region would)."""
    opts = _options(load_map("tuning/block_loop_north"))
    _loop_scans(opts, None)
    assert opts.crossings.arrays["hidden"][0, _north_east(opts)].sum() > 1.0


def test_a_robot_aims_at_the_door_it_saw_not_at_the_wall():
    opts = _office_options()
    _look(
        opts.crossings,
        [(2.0, 3.0, -math.pi / 2), (1.0, 3.2, -math.pi / 2), (3.2, 3.0, -math.pi / 2)],
    )
    opts.crossings.arrays["blocked"][0, _wc_border(opts), :] = 5.0
    opts.begin_trial(torch.tensor([0]))
    r = opts.region_names.index("west_office")
    k = opts.labels[r].index("offices>west_door")
    opts.arrays["choice"][0, r] = k  # the door's option in force
    _, option, _, aim, _ = opts.steer(torch.tensor([r]), torch.tensor([[2.0, 3.0, -1.5]]), False)
    assert int(option[0]) == k
    assert aim[0, 0].item() == pytest.approx(2.0, abs=0.2)  # the door, not x = 3.5
    assert aim[0, 1].item() == pytest.approx(2.05 - 0.4, abs=1e-6)


def test_an_option_given_up_is_given_up_for_the_trial_only():
    opts = _office_options()
    r = opts.region_names.index("west_office")
    k = opts.labels[r].index("wc>middle_office")
    opts._stall(0, r, k)
    assert opts._trial_stalled[0, r, k]
    assert not opts.critic.stalls  # nothing is banned for good
    opts.begin_trial(torch.tensor([0]))
    assert not opts._trial_stalled.any()


def test_in_the_goals_region_the_goal_is_never_given_up():
    opts = _office_options()
    r = opts.region_names.index("east_office")
    opts._stall(0, r, 0)
    assert not opts._trial_stalled[0, r, 0]
    w = opts.region_names.index("west_office")
    opts._stall(0, w, 0)
    assert opts._trial_stalled[0, w, 0]


def _credited(choices: list[int], *overrides: str) -> tuple[torch.Tensor, torch.Tensor]:
    """The west office's option critic (q, n) after one trial that took ``choices[step]`` (an
    index into the region's options) at each step, reward -1 per step, a new choice marked
    wherever the option changes."""
    from tensordict import TensorDict

    from symrl.assembly import build_policy, build_update

    config = load_config(
        "paper",
        [
            "crossings.enabled=true",
            "experts.learning=false",
            "options.remembered_way=false",
            "options.goal_scans=false",
            *overrides,
        ],
    )
    policy = build_policy(config, OFFICE, [0])
    loss = build_update(config, policy)
    r = policy.region_names.index("west_office")
    pose, sonar = torch.tensor([[2.0, 4.5, 0.0]]), torch.ones(1, ROBOT.n_sensors)
    for step, option in enumerate(choices):
        td = TensorDict(
            {
                "option_entry": torch.tensor([step == 0 or option != choices[step - 1]]),
                "region": torch.tensor([r]),
                "option": torch.tensor([option]),
                "pose": pose,
                "sonar": sonar,
                "next": TensorDict(
                    {
                        "reward": torch.tensor([[-1.0]]),
                        "pose": pose,
                        "sonar": sonar,
                        "region": torch.tensor([r]),
                    },
                    [1],
                ),
            },
            [1],
        )
        loss(td)
    total = -float(len(choices))
    loss.end_trial(torch.tensor([0]), torch.tensor([total]), torch.tensor([True]))
    assert torch.isnan(loss.returns.choice_return).all()  # ready for the next trial
    critic = policy.options.critic
    return critic.q[0, r], critic.n[0, r]


def test_every_choice_is_credited_with_the_return_to_go_from_it():
    """A region's first option, given up after 4 actions of reward -1, and the one chosen then,
    which reaches the goal 2 actions later: the first is credited with -6, the second -2."""
    first, second = 0, 1
    q, count = _credited([first] * 4 + [second] * 2)
    assert count[first] == 1 and q[first] == pytest.approx(-6.0)
    assert count[second] == 1 and q[second] == pytest.approx(-2.0)


@pytest.mark.parametrize("credit, again", [("first", -6.0), ("last", -2.0)])
def test_an_option_chosen_again_is_credited_from_its_first_or_last_choice(credit, again):
    """The first option for 2 actions, given up; the second for 2, given up; the first again
    for 2 to the goal. From its first choice the first option carries the whole trial (-6);
    from its last, only the tail (-2). The second is credited -4 either way."""
    q, count = _credited([0, 0, 1, 1, 0, 0], f"option_critic.credit={credit}")
    assert count[0] == 1 and q[0] == pytest.approx(again)
    assert count[1] == 1 and q[1] == pytest.approx(-4.0)
