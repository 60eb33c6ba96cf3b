"""Every switch of the paper recipe (issue #4) pinned through the real policy, loss and train()."""

from __future__ import annotations

import math

import pytest
import torch
from learner_helpers import obs, obs_td, transition
from torchrl.envs.utils import ExplorationType, set_exploration_type

from symrl.learner.config import LearnerConfig, load_config
from symrl.learner.loss import TeseoLoss

ROOM_POSE = (0.0, 0.0, 0.0)


def test_defaults_are_literal_and_the_paper_recipe_sets_the_switches():
    literal = load_config("paper_literal").learner
    assert not literal.options and not literal.residual
    paper = load_config("paper").learner
    assert paper.options and paper.residual and paper.subgoal_past
    assert paper.option_critic == "mean" and paper.option_try_untried
    assert (paper.temperature0, paper.temperature_min) == (0.1, 0.0)
    assert not paper.subgoal_on_line and paper.subgoal_min_clearance == 0.45
    assert paper.shield and paper.shield_margin == 0.06 and not literal.shield


def test_options_off_steers_at_the_goal(make_policy):
    policy = make_policy()
    assert policy.options is None
    o = obs(pose=ROOM_POSE, goal=(4.5, -0.46))
    assert policy.reflex_target(o, 0) == pytest.approx(-0.46)


def test_options_on_steers_at_the_chosen_subgoal(make_policy):
    policy = make_policy(options=True)
    table = policy.options.table
    policy.options.n.fill_(1)  # every option tried: greedy on q
    room = policy.region_names.index("room")
    k = table.labels[room].index("l2@+0.0/0.0")  # the door centre (3.5, -0.5)
    policy.options.q[room, k] = 1.0
    o = obs(pose=ROOM_POSE, goal=(4.5, -0.46))
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        angle = policy.reflex_target(o, room)
    assert angle == pytest.approx(math.atan2(-0.5, 3.5), abs=1e-6)


def test_option_critic_learns_from_the_loss_rewards_and_end_trial(make_policy):
    policy = make_policy(options=True, residual=True)
    loss = TeseoLoss(policy)
    a, b = obs(pose=ROOM_POSE), obs(pose=(0.2, 0.0, 0.0))
    for reward in (-1.0, -2.0):
        loss.update(transition(policy, a, b, reward))
    record = {"reached_goal": True, "total_reinforcement": -3.0}
    loss.end_trial(record)
    room = policy.region_names.index("room")
    option = int(record["option_room"])  # the option chosen this trial is in the record
    assert int(policy.options.n[room, option]) == 1
    assert float(policy.options.q[room, option]) == pytest.approx(-3.0)
    assert record["epsilon"] == pytest.approx(0.3 * 0.8)


def test_option_switches_reach_the_option_learner(make_policy):
    policy = make_policy(
        options=True,
        option_epsilon=0.5,
        option_epsilon_decay=0.9,
        option_greedy_after=7,
        option_try_untried=False,
        option_reach=0.4,
        option_critic="best",
        option_risk=0.5,
    )
    cfg = policy.options.learner.config
    assert (cfg.epsilon, cfg.epsilon_decay, cfg.greedy_after) == (0.5, 0.9, 7)
    assert (cfg.try_untried, cfg.reach, cfg.critic, cfg.risk) == (False, 0.4, "best", 0.5)


def test_subgoal_past_gives_the_corridor_points_past_the_door(make_policy):
    corridor = make_policy().region_names.index("corridor")
    with_past = make_policy(options=True).options.table
    without = make_policy(options=True, subgoal_past=False).options.table
    assert int(with_past.counts[corridor]) > 1
    assert int(without.counts[corridor]) == 1


def test_residual_new_neurons_start_at_zero_and_act_on_top_of_the_reflex(make_policy):
    policy = make_policy(residual=True, temperature0=0.0)
    o = obs(pose=ROOM_POSE, goal=(4.5, -0.46))
    assert policy.new_neuron_action(o, 0) == 0.0
    td = policy(obs_td(o))  # grows the first neuron (p = 0)
    reflex = policy.reflex_action(o, int(td["expert"]))
    assert float(td["action"]) == pytest.approx(reflex, abs=1e-6)
    expert = policy.experts[int(td["expert"])]
    expert.rows.actions[0] = 0.25  # a learned correction
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        td = policy(obs_td(o))
    assert float(td["action"]) == pytest.approx(reflex + 0.25, abs=1e-6)


def test_residual_without_reflex_keeps_random_new_actions(make_policy):
    policy = make_policy(residual=True, reflex=False)
    actions = {policy.new_neuron_action(obs(), 0) for _ in range(5)}
    assert len(actions) == 5 and 0.0 not in actions


def test_absolute_actions_when_residual_is_off(make_policy):
    policy = make_policy(temperature0=0.0)
    o = obs(pose=ROOM_POSE, goal=(4.5, -0.46))
    policy(obs_td(o))
    policy.experts[0].rows.actions[0] = 0.25
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        td = policy(obs_td(o))
    assert float(td["action"]) == pytest.approx(0.25, abs=1e-6)


def test_checkpoint_keeps_the_option_critic(make_policy):
    policy = make_policy(options=True)
    policy.options.q[0, 1] = -4.5
    policy.options.n[0, 1] = 3
    fresh = make_policy(options=True)
    fresh.load_state_dict(policy.state_dict())
    assert float(fresh.options.q[0, 1]) == -4.5 and int(fresh.options.n[0, 1]) == 3
    assert fresh.options.learner.q is fresh.options.q


def test_short_paper_run_is_deterministic_and_records_options():
    from symrl.train import train

    config = load_config("paper", ["run.trials=3", "run.seed=6"])
    a = train(config, progress=False).trials
    b = train(load_config("paper", ["run.trials=3", "run.seed=6"]), progress=False).trials
    assert [t["total_reinforcement"] for t in a] == [t["total_reinforcement"] for t in b]
    assert all("option_room" in t for t in a)
    assert all(t["reached_goal"] for t in a)
    assert sum(t["shielded"] for t in a) > 0  # the shield is at work ...
    assert sum(t["collisions"] for t in a) == 0  # ... and nothing collides


def _ir_wall_ahead(rim: float = 0.1) -> torch.Tensor:
    """IR readings of a wall straight ahead (sensors 23, 0, 1) at ``rim`` metres."""
    from symrl.world.robot import RobotConfig

    ir = torch.zeros(24)
    ir[[23, 0, 1]] = float(RobotConfig().reflectance(rim))
    return ir


def test_shield_replaces_a_move_into_a_wall_and_the_neuron_remembers_it(make_policy):
    policy = make_policy(shield=True, residual=True, temperature0=0.0)
    o = obs(pose=ROOM_POSE, goal=(4.0, 0.0))._replace(ir=_ir_wall_ahead())
    td = policy(obs_td(o))
    alpha = float(td["action"])
    assert bool(td["shielded"]) and abs(alpha) > math.radians(30)
    expert, winner = int(td["expert"]), int(td["winner"])
    base = policy.reflex_action(o, expert)
    rows = policy.experts[expert].rows
    assert float(rows.taken[winner]) == pytest.approx(alpha - base, abs=1e-6)
    # off: the same observation is not filtered
    plain = make_policy(residual=True, temperature0=0.0)(obs_td(o))
    assert not bool(plain["shielded"])


def test_shield_leaves_free_space_moves_alone(make_policy):
    shielded = make_policy(shield=True)(obs_td(obs(pose=ROOM_POSE)))
    plain = make_policy()(obs_td(obs(pose=ROOM_POSE)))
    assert not bool(shielded["shielded"])
    assert float(shielded["action"]) == float(plain["action"])


def test_config_rejects_bad_option_values():
    from symrl.learner.config import ConfigError

    with pytest.raises(ConfigError, match="option_epsilon"):
        load_config("paper", ["learner.option_epsilon=1.5"])
    with pytest.raises(ConfigError, match="option_critic"):
        load_config("paper", ["learner.option_critic=max"])
    with pytest.raises(ConfigError, match=r"learner.shield_margin=-0.1"):
        load_config("paper", ["learner.shield_margin=-0.1"])
    assert isinstance(LearnerConfig().options, bool)


def test_greedy_option_choice_does_not_consume_exploration(make_policy):
    policy = make_policy(options=True, option_epsilon=1.0, option_try_untried=False)
    policy.options.n.fill_(1)
    policy.options.q[0] = torch.linspace(-9, 0, policy.options.q.shape[1], dtype=torch.float64)
    policy.options.q[0, ~policy.options.table.valid[0]] = -100.0
    best = int(torch.where(policy.options.table.valid[0], policy.options.q[0], -1e9).argmax())
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        policy.reflex_target(obs(pose=ROOM_POSE), 0)
    assert policy.options.learner.choice[0] == best


def test_subgoal_on_line_and_min_clearance_shape_the_table(make_policy):
    room = make_policy().region_names.index("room")
    full = make_policy(options=True).options.table.labels[room]
    assert "l2@+0.0/0.0" in full and "l2@+0.8/0.4" in full
    past_only = make_policy(options=True, subgoal_on_line=False).options.table.labels[room]
    assert all(label == "goal" or label.endswith("/0.4") for label in past_only)
    safe = make_policy(
        options=True, subgoal_on_line=False, subgoal_min_clearance=0.45
    ).options.table.labels[room]
    assert "l2@+0.8/0.4" not in safe  # (3.9, -0.69): 0.34 m from the door post
    assert "l3@+0.8/0.4" in safe  # (4.15, -0.69): 0.51 m


def test_option_avoidance_config_parses_and_rejects_bad_values():
    from symrl.learner.config import ConfigError

    assert load_config("paper").learner.option_avoidance == []  # paper: a fixed softer reflex
    assert load_config("paper_literal").learner.option_avoidance == []
    three = load_config("paper", ["learner.option_avoidance=[0.7, 0.5, 0.3]"])
    assert three.learner.option_avoidance == [0.7, 0.5, 0.3]
    with pytest.raises(ConfigError, match=r"learner.option_avoidance=\[0.7, 2.0\]"):
        load_config("paper", ["learner.option_avoidance=[0.7, 2]"])
    with pytest.raises(ConfigError, match=r"learner.option_avoidance\[0\]='x'"):
        load_config("paper", ["learner.option_avoidance=[x]"])
    with pytest.raises(ConfigError, match="learner.options and learner.reflex"):
        load_config("paper_literal", ["learner.option_avoidance=[0.5]"])


def test_option_avoidance_steers_with_the_chosen_desirability(make_policy):
    from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig

    policy = make_policy(options=True, residual=True, option_avoidance=[0.7, 0.2])
    room = policy.region_names.index("room")
    policy.options.avoid_n.fill_(1)  # both tried: greedy on the critic, which prefers d_a 0.2
    policy.options.avoid_q[room] = torch.tensor([-9.0, -8.0], dtype=torch.float64)
    sonar = [0.5] * 24
    sonar[0] = sonar[1] = sonar[23] = 0.06  # a wall ahead: avoidance has something to say
    o = obs(sonar=sonar, pose=ROOM_POSE)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        got = policy.reflex_action(o, room)
        target = policy.reflex_target(o, room)
    soft = FuzzyReflex(ReflexConfig(d_a=0.2)).angle(o.sonar, target)
    hard = FuzzyReflex(ReflexConfig(d_a=0.7)).angle(o.sonar, target)
    assert got == pytest.approx(soft) and soft != pytest.approx(hard)


def test_option_avoidance_critic_learns_and_survives_a_checkpoint(make_policy):
    policy = make_policy(options=True, residual=True, option_avoidance=[0.7, 0.5, 0.3])
    loss = TeseoLoss(policy)
    a, b = obs(pose=ROOM_POSE), obs(pose=(0.2, 0.0, 0.0))
    loss.update(transition(policy, a, b, -2.0))
    record = {"reached_goal": True, "total_reinforcement": -2.0}
    loss.end_trial(record)
    room = policy.region_names.index("room")
    d_a = record["avoid_room"]
    k = [0.7, 0.5, 0.3].index(d_a)
    assert int(policy.options.avoid_n[room, k]) == 1
    assert float(policy.options.avoid_q[room, k]) == pytest.approx(-2.0)
    fresh = make_policy(options=True, residual=True, option_avoidance=[0.7, 0.5, 0.3])
    fresh.load_state_dict(policy.state_dict())
    assert float(fresh.options.avoid_q[room, k]) == pytest.approx(-2.0)
    assert fresh.options.avoid_learner.q is fresh.options.avoid_q


def test_paper_reflex_ignores_a_wall_alongside_that_the_section4_reflex_swerves_from():
    from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig

    sonar = torch.ones(24, dtype=torch.float64)
    sonar[[20, 21, 22]] = 0.4 / 5.0  # a wall 0.4 m away, front-right (a corridor wall at 45 deg)
    section4 = FuzzyReflex(ReflexConfig()).angle(sonar, 0.0)
    paper = FuzzyReflex(load_config("paper").reflex).angle(sonar, 0.0)
    assert section4 > math.radians(10)  # FR near -> LEFT: a turn away from a harmless wall
    assert paper == pytest.approx(0.0)  # the goal straight ahead wins
    sonar[[20, 21, 22]] = 0.15 / 5.0  # closer than 0.35 m: the paper reflex avoids it too
    assert FuzzyReflex(load_config("paper").reflex).angle(sonar, 0.0) > math.radians(10)
