"""The policy acts: input coding, region gate, novel states, exploration, greedy mode, residual
experts, the shield, options, and per-robot controller states."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from learner_helpers import N_SENSORS, POSES, act, config_of, observation, place, policy, stack
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.assembly import build_policy
from symrl.world.batched_env import BatchedWorldEnv
from symrl.world.geometry import Walls
from symrl.world.worldmap import load_map

GREEDY = ExplorationType.DETERMINISTIC


def _reflex(p, obs, target=None) -> float:
    goal = obs["goal"][:, 1] if target is None else torch.tensor([target])
    return float(p.reflex(obs["sonar"].double(), goal.double())[0])


def test_input_is_sonars_and_goal_codes():
    p = policy()
    obs = observation(sonar=0.25, goal=(p.perception.start_distance * 0.5, 0.0))
    x = p.perceive(obs["sonar"], obs["odometry"], obs["goal"]).x[0]
    assert x.shape == (32,) and p.input_dim == 32
    assert torch.equal(x[:24], torch.full((24,), 0.25))
    mu = torch.arange(8) / 7
    assert torch.allclose(x[24:], torch.exp(-((mu - 0.5) ** 2)))
    far_goal = torch.tensor([p.perception.start_distance * 3])
    far = p.perception.encode(obs["sonar"], far_goal)[0]  # rho clipped to 1
    assert torch.allclose(far[24:], torch.exp(-((mu - 1.0) ** 2)))


def test_region_gate_picks_the_expert():
    p = policy(seeds=range(4))
    assert p.expert_names == ("room", "concave", "door", "corridor")
    obs = stack(*(observation(pose=pose) for pose in POSES.values()))
    per = p.perceive(obs["sonar"], obs["odometry"], obs["goal"])
    assert per.region.tolist() == per.expert.tolist() == [0, 1, 2, 3]
    assert per.winner.tolist() == [-1] * 4 and per.novel.all()
    one = policy("no_partition", seeds=range(4))  # told no regions: one region, one expert
    assert one.expert_names == ("all",) and one.region_names == ("all",)
    per = one.perceive(obs["sonar"], obs["odometry"], obs["goal"])
    assert per.region.tolist() == [0, 0, 0, 0] and per.expert.tolist() == [0, 0, 0, 0]


@pytest.mark.parametrize("recipe", ["paper_map", "paper_literal"])  # pose input, sensor input
def test_perceiving_again_follows_the_observation_not_the_tensor(recipe):
    """Perception follows the observation's values: the same values give the same gate and
    inputs, an observation changed in place, or another one, is perceived afresh."""
    p = policy(recipe, seeds=range(2))
    obs = stack(observation(pose=POSES["room"]), observation(0.3, POSES["door"], (2.0, 0.5)))
    first = p.perceive(obs["sonar"], obs["odometry"], obs["goal"])
    again = p.perceive(obs["sonar"].clone(), obs["odometry"].clone(), obs["goal"].clone())
    assert torch.equal(again.region, first.region) and torch.equal(again.x, first.x)
    obs["odometry"][0] = obs["odometry"][1]  # in place: the same tensor, the door's pose
    obs["sonar"][0] = obs["sonar"][1]
    obs["goal"][0] = obs["goal"][1]
    moved = p.perceive(obs["sonar"], obs["odometry"], obs["goal"])
    fresh = policy(recipe, seeds=range(2)).perceive(obs["sonar"], obs["odometry"], obs["goal"])
    assert moved.region.tolist() == [2, 2] == fresh.region.tolist()
    assert torch.equal(moved.x, fresh.x) and not torch.equal(moved.x, first.x)


def test_acting_writes_the_decision_and_grows_nothing():
    p = policy()
    td = act(p, observation())
    for key in p.out_keys:
        assert key in td, key
    assert td["action"].shape == (1, 1) and td["action"].dtype == torch.float32
    assert bool(td["novel"][0]) and int(td["winner"][0]) == -1
    assert int(p.neurons().sum()) == 0  # the update grows, the policy only acts


def test_novel_state_acts_as_its_new_neuron_would():
    obs = observation(sonar=0.5, goal=(4.0, 0.6), state_reward=-0.4)
    # paper_literal: p = the reflex's action, u = state_reward
    p = policy()
    td = act(p, obs.clone())
    reflex = _reflex(p, obs)
    assert float(td["proto"][0]) == pytest.approx(reflex)
    assert float(td["sigma"][0]) == pytest.approx(0.3 / (1 + math.exp(-0.4)))
    assert float(td["action"][0, 0]) == pytest.approx(reflex + float(td["xi"][0]), abs=1e-6)
    assert float(td["taken"][0]) == pytest.approx(float(td["action"][0, 0]), abs=1e-6)
    # residual experts: p = 0 on top of the reflex
    r = policy("paper_map", "options.enabled=false", "shield.enabled=false")
    td = act(r, obs.clone())
    assert float(td["proto"][0]) == 0.0
    reflex = _reflex(r, obs)  # the paper recipe's own reflex (its output sets differ)
    assert float(td["action"][0, 0]) == pytest.approx(reflex + float(td["xi"][0]), abs=1e-6)
    assert float(td["taken"][0]) == pytest.approx(float(td["xi"][0]), abs=1e-6)  # minus base
    # no reflex: a uniform random action in [-pi, pi], a new one each time
    n = policy("no_reflex")
    protos = [float(act(n, obs.clone())["proto"][0]) for _ in range(8)]
    assert len(set(protos)) == 8 and all(-math.pi <= a <= math.pi for a in protos)


def test_known_state_acts_with_its_neuron():
    p = policy()
    obs = observation()
    place(p, obs, action=0.2, utility=-1.0, mean=0.05)
    sigma = 0.3 / (1 + math.exp(-1.0))  # T / (1 + e^u)
    draws = []
    for _ in range(300):
        td = act(p, obs.clone())
        assert not bool(td["novel"][0]) and int(td["winner"][0]) == 0
        assert float(td["sigma"][0]) == pytest.approx(sigma)
        xi = float(td["xi"][0])
        assert float(td["action"][0, 0]) == pytest.approx(0.2 + xi, abs=1e-6)
        draws.append(xi)
    xs = torch.tensor(draws)
    assert abs(float(xs.mean()) - 0.05) < 4 * sigma / math.sqrt(300)
    assert abs(float(xs.std()) - sigma) < 0.15 * sigma
    p.experts.actions[0, 0, 0] = 3.1
    p.experts.means[0, 0, 0] = 1.0
    assert float(act(p, obs.clone())["action"][0, 0]) == pytest.approx(math.pi)  # clipped


def test_sigma_follows_the_temperature():
    p = policy()
    obs = observation(state_reward=-0.5)
    p.progress.temperature.fill_(0.0)
    td = act(p, obs.clone())
    assert float(td["sigma"][0]) == 0.0 and float(td["xi"][0]) == 0.0


def test_greedy_is_deterministic_and_draws_nothing():
    p = policy()
    obs = observation()
    place(p, obs, action=0.2, utility=-1.0, mean=0.05)
    novel = observation(sonar=0.9)
    states = [g.get_state() for g in p.generators]
    drawn = p._drawn
    with set_exploration_type(GREEDY):
        first = [act(p, obs.clone()), act(p, novel.clone())]
        second = [act(p, obs.clone()), act(p, novel.clone())]
    assert float(first[0]["action"][0, 0]) == pytest.approx(0.25, abs=1e-6)  # p + mu
    assert float(first[1]["action"][0, 0]) == pytest.approx(_reflex(p, novel), abs=1e-6)
    for a, b in zip(first, second, strict=True):
        for key in ("action", "xi", "sigma", "taken", "winner"):
            assert torch.equal(a[key], b[key]), key
        assert float(a["sigma"][0]) == 0.0
    assert p._drawn == drawn
    assert all(torch.equal(g.get_state(), s) for g, s in zip(p.generators, states, strict=True))
    # the next exploring action draws what it would have drawn without the greedy ones
    fresh = policy()
    place(fresh, obs, action=0.2, utility=-1.0, mean=0.05)
    assert torch.equal(act(p, obs.clone())["xi"], act(fresh, obs.clone())["xi"])


def test_greedy_residual_expert_adds_its_correction_to_the_reflex():
    p = policy("paper_map", "options.enabled=false", "shield.enabled=false")
    obs = observation(goal=(4.5, -0.46))
    place(p, obs, action=0.25)
    with set_exploration_type(GREEDY):
        td = act(p, obs.clone())
    assert float(td["action"][0, 0]) == pytest.approx(_reflex(p, obs) + 0.25, abs=1e-6)
    absolute = policy()
    place(absolute, obs, action=0.25)
    with set_exploration_type(GREEDY):
        assert float(act(absolute, obs.clone())["action"][0, 0]) == pytest.approx(0.25, abs=1e-6)


def test_without_learning_the_reflex_drives():
    p = policy("reflex_only")
    obs = observation(sonar=0.03, goal=(3.0, -1.0))
    td = act(p, obs.clone())
    assert float(td["action"][0, 0]) == pytest.approx(_reflex(p, obs), abs=1e-6)
    assert int(td["winner"][0]) == -1 and float(td["proto"][0]) == 0.0
    assert float(td["sigma"][0]) == 0.0 and int(p.neurons().sum()) == 0


def _facing_the_wall():
    """A robot 0.14 m (rim) in front of the dividing wall, facing it."""
    env = BatchedWorldEnv("hailu2001", size=1, seeds=[0], noise=False)
    env.set_starts(np.array([[3.1, 1.5, 0.0]]))
    td = env.reset()
    env.close()
    return td


def test_shield_replaces_a_move_into_a_wall():
    obs = _facing_the_wall()
    shielded = policy("paper_literal", "shield.enabled=true")
    plain = policy("paper_literal")
    for p in (shielded, plain):
        place(p, obs, action=0.0)  # the neuron drives straight into the wall
    with set_exploration_type(GREEDY):
        a, b = act(shielded, obs.clone()), act(plain, obs.clone())
    assert not bool(b["shielded"][0]) and float(b["action"][0, 0]) == 0.0
    alpha = float(a["action"][0, 0])
    assert bool(a["shielded"][0]) and abs(alpha) > math.radians(30)
    assert float(a["taken"][0]) == pytest.approx(alpha, abs=1e-6)  # the neuron remembers it
    # in free space the shield changes nothing
    free = observation()
    with set_exploration_type(GREEDY):
        c, d = act(shielded, free.clone()), act(plain, free.clone())
    assert not bool(c["shielded"][0]) and torch.equal(c["action"], d["action"])


def test_options_choose_at_the_first_entry_of_a_region_per_trial():
    p = policy("paper_map", seeds=(0, 1))
    room, door = observation(), observation(pose=POSES["door"])
    both = stack(room, room)
    td = act(p, both.clone())
    assert td["option_entry"].tolist() == [True, True]
    assert (td["option"] >= 0).all()
    chosen = td["option"].clone()
    for _ in range(3):  # the same region again: no new choice, the same option
        td = act(p, both.clone())
        assert td["option_entry"].tolist() == [False, False]
        assert torch.equal(td["option"], chosen)
    td = act(p, stack(door, room))  # robot 0 enters the door region
    assert td["option_entry"].tolist() == [True, False]
    td = act(p, stack(room, room))  # back in the room: the room's choice still holds
    assert td["option_entry"].tolist() == [False, False] and torch.equal(td["option"], chosen)
    p.begin_trial(torch.tensor([1]))  # robot 1 starts a new trial: it chooses again
    td = act(p, both.clone())
    assert td["option_entry"].tolist() == [False, True]
    assert p.options.choice[1].tolist().count(-1) == len(p.region_names) - 1
    off = act(policy("paper_literal"), room.clone())
    assert int(off["option"][0]) == -1 and not bool(off["option_entry"][0])


def test_options_steer_the_reflex_at_the_chosen_subgoal():
    # (no goal lead: the sub-goal from the region's first step)
    p = policy(
        "paper_map",
        "shield.enabled=false",
        "option_critic.try_untried=false",
        "options.goal_lead_deg=0",
    )
    r = p.region_names.index("room")
    labels = p.options.labels[r]
    k = next(i for i, name in enumerate(labels) if name not in ("goal", "route"))
    p.options.critic.n[0, r] = 1  # everything tried: greedy on q
    p.options.critic.q[0, r] = -5.0
    p.options.critic.q[0, r, k] = -1.0
    obs = observation(goal=(4.5, -0.46))
    with set_exploration_type(GREEDY):
        td = act(p, obs.clone())
    assert int(td["option"][0]) == k
    px, py = p.options.points[r, k].tolist()
    target = math.atan2(py, px)  # from the pose (0, 0, 0)
    assert float(td["action"][0, 0]) == pytest.approx(_reflex(p, obs, target), abs=1e-5)


def test_robot_states_round_trip():
    p = policy("paper_map", seeds=(4, 5))
    for b, (sonar, n) in enumerate(((0.2, 3), (0.7, 70))):  # robot 1 outgrows the capacity
        for k in range(n):
            place(p, observation(sonar=sonar + 0.003 * k), action=0.01 * k, utility=-k, row=b)
    p.progress.temperature[1] = 0.05
    p.progress.best_total[0] = -9.0
    p.options.critic.q[1, 0, 1] = -4.5
    p.options.critic.n[1, 0, 1] = 3
    config = config_of(p)
    single = build_policy(config, p.knowledge, [5])
    single.load_state_dict(p.robot_state(1))
    assert single.neurons().tolist() == [p.neurons()[1].tolist()]
    assert float(single.progress.temperature[0]) == 0.05
    assert float(single.options.critic.q[0, 0, 1]) == -4.5
    n = int(p.experts.count[1, 0])
    assert torch.equal(single.experts.centres[0, 0, :n], p.experts.centres[1, 0, :n])
    # several controllers side by side, in any order, with different capacities
    small = build_policy(config, p.knowledge, [4])
    small.load_state_dict(p.robot_state(0))
    both = build_policy(
        config, p.knowledge, [4, 5], states=[small.state_dict(), single.state_dict()]
    )
    for key, value in p.state_dict().items():
        assert torch.equal(both.state_dict()[key], value), key
    swapped = build_policy(config, p.knowledge, [0, 0], states=[p.robot_state(1), p.robot_state(0)])
    assert swapped.neurons().tolist() == p.neurons().flip(0).tolist()
    assert swapped.progress.best_total.tolist() == [-math.inf, -9.0]
    # each robot acts as its controller alone
    obs = stack(observation(sonar=0.7), observation(sonar=0.2))
    with set_exploration_type(GREEDY):
        td = act(swapped, obs.clone())
        alone = act(single, observation(sonar=0.7))
    assert torch.equal(td["action"][0], alone["action"][0])
    assert int(td["winner"][0]) == int(alone["winner"][0]) >= 0


def test_a_robots_actions_do_not_depend_on_the_batch():
    """Robot b of a batch draws and acts as the same seed alone."""
    obs = [observation(sonar=0.3), observation(sonar=0.6, pose=POSES["door"])]
    batch = policy("paper_map", seeds=(11, 12))
    alone = [policy("paper_map", seeds=(s,)) for s in (11, 12)]
    for _ in range(5):
        td = act(batch, stack(*obs))
        for b, p in enumerate(alone):
            one = act(p, obs[b].clone())
            for key in ("action", "xi", "option", "proto"):
                assert torch.equal(td[key][b], one[key][0]), key


def test_pose_input_is_the_odometry_pose_with_a_heading_scale():
    p = policy("paper_literal", "experts.input=pose", "experts.heading_scale=0.5")
    obs = observation(pose=(1.0, -2.0, math.pi / 2), sonar=0.3)
    x = p.perceive(obs["sonar"], obs["odometry"], obs["goal"]).x[0]
    assert p.input_dim == 4 and p.experts.dim == 4
    assert torch.allclose(x, torch.tensor([1.0, -2.0, 0.0, 0.5]), atol=1e-6)
    # the sonars do not enter: another reading at the same pose is the same input
    other = observation(pose=(1.0, -2.0, math.pi / 2), sonar=0.9)
    assert torch.equal(p.perceive(other["sonar"], other["odometry"], other["goal"]).x[0], x)


def test_pose_input_revisits_a_neuron_within_the_radius_in_metres():
    p = policy("paper_literal", "experts.input=pose", "experts.novelty_radius=0.5")
    place(p, observation(pose=(0.0, 0.0, 0.0)))
    near = observation(pose=(0.3, 0.2, 0.1), sonar=0.9)  # 0.37 m and 0.1 rad away
    far = observation(pose=(0.6, 0.0, 0.0))
    assert not bool(p.perceive(near["sonar"], near["odometry"], near["goal"]).novel[0])
    assert bool(p.perceive(far["sonar"], far["odometry"], far["goal"]).novel[0])


def test_with_map_localisation_the_gate_and_the_goal_follow_the_scan_not_the_odometry():
    """A robot in the door whose odometry has drifted 0.3 m back into the room: without
    localisation the gate routes it by the odometry (room), with it by its sonar scan (door),
    and the goal's distance and angle are recomputed from the corrected pose."""
    true = np.array([[3.55, -0.5, 0.1]])
    walls = Walls(load_map("hailu2001").segments)
    offsets = np.arange(N_SENSORS) * (2 * math.pi / N_SENSORS)
    rays = walls.cast_many(true[:, 0], true[:, 1], true[:, 2:3] + offsets, 5.26)
    sonar = (np.clip(rays - 0.26, 0.0, 5.0) / 5.0)[0].tolist()
    obs = observation(sonar=sonar, pose=(3.25, -0.5, 0.1), goal=(1.0, 0.0))
    plain = policy("paper_map")
    # an odometry 0.3 m off at a trial's first observation: the config's advice for such a
    # start is about 5 Gauss-Newton steps (a reset's odometry is exact, so paper takes 2)
    localised = policy("paper_map", "localize.enabled=true", "localize.iterations=5")
    assert plain.perceive(obs["sonar"], obs["odometry"], obs["goal"]).region.tolist() == [0]
    assert localised.perceive(obs["sonar"], obs["odometry"], obs["goal"]).region.tolist() == [2]
    pose, goal = localised.perception.belief(obs["sonar"], obs["odometry"], obs["goal"])
    assert np.allclose(pose.numpy(), true, atol=0.01)
    g = localised.knowledge.goal
    assert math.isclose(float(goal[0, 0]), math.hypot(g.x - 3.55, g.y + 0.5), abs_tol=0.01)
    # without localisation the belief is the observation itself
    same = plain.perception.belief(obs["sonar"], obs["odometry"], obs["goal"])
    assert same[0] is obs["odometry"] and same[1] is obs["goal"]


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_trials_first_action_turns_straight_at_an_aim_behind_the_robot(side):
    """Facing away from the goal (``paper``'s first option, the goal), the first action of a
    trial is the whole turn to the aim, mirrored with the pose; later actions, and a first
    action with the aim less than start_turn_deg off, follow the reflex (on the route the turn
    applies at every step: tests/learner/test_options.py)."""
    args = ("shield.enabled=false", "experts.learning=false", "options.start_turn_deg=90")
    p = policy("paper", *args)
    heading = side * 2.6  # the goal (4, -2) is ~150 degrees off from (0, 0)
    behind = observation(pose=(0.0, 0.0, heading))
    td = act(p, behind.clone())
    aim = math.atan2(-2.0, 4.0) - heading
    aim = math.remainder(aim, 2 * math.pi)
    assert abs(aim) > math.radians(90)
    assert float(td["action"][0, 0]) == pytest.approx(aim, abs=1e-5)
    again = act(p, behind.clone())  # the trial's second action: the reflex's (at most 45 degrees)
    assert abs(float(again["action"][0, 0])) <= math.radians(45) + 1e-6
    p.begin_trial(torch.tensor([0]))  # a new trial turns again
    assert float(act(p, behind.clone())["action"][0, 0]) == pytest.approx(aim, abs=1e-5)
    off = policy("paper", *args[:2], "options.start_turn_deg=null")
    assert abs(float(act(off, behind.clone())["action"][0, 0])) <= math.radians(45) + 1e-6
    ahead = policy("paper", *args)  # the aim 26 degrees off: the reflex's action
    obs = observation(pose=(0.0, 0.0, 0.0))
    assert float(act(ahead, obs.clone())["action"][0, 0]) == pytest.approx(
        _reflex(ahead, obs, math.atan2(-2.0, 4.0)), abs=1e-5
    )


def test_the_perception_is_a_submodule_kept_out_of_the_state_dict():
    p = policy("paper_map")
    assert dict(p.named_children())["perception"] is p.perception_transform()
    keys = list(p.state_dict())
    assert not any("perception" in k for k in keys)
    assert any(k.startswith("mapper.") for k in keys) and "code_centres" in keys
    q = policy("paper_map")
    q.load_state_dict(p.state_dict())  # strict: nothing missing, nothing unexpected
    with pytest.raises(RuntimeError, match="Missing key"):
        q.load_state_dict({k: v for k, v in p.state_dict().items() if k != "code_centres"})
