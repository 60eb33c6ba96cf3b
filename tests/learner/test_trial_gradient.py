"""The trial gradient: the adjoint against central differences of the replayed model, its
mirror symmetry, its sign where the answer is known, and the update rule it drives."""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest
import torch

from symrl import ENV_ID
from symrl.knowledge.reflex import FuzzyReflex
from symrl.learner.config import load_config
from symrl.learner.trial_gradient import reflex_partials, trial_gradient
from symrl.train import train_batch
from symrl.world.physics import wrap_angle as _wrap

RANGE, CLOSE, STEP, GOAL = 5.0, 0.3, 0.2, (4.0, -2.0)
REFLEX = FuzzyReflex(load_config("paper_map").reflex)


def _recorded_trial(seed: int = 5):
    """One noisy trial of the reflex steering at the door, then the goal: what the update
    records (odometry, readings before and after each move, aims, the corrections held)."""
    env = gymnasium.make(ENV_ID, map="hailu2001", noise=True)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    poses = [np.asarray(obs["odometry"], dtype=np.float64)]
    sonar, after, aims, extra = [], [], [], []
    done = False
    while not done:
        x, y, h = poses[-1]
        aim = np.array((3.9, -0.5)) if x < 3.6 else np.array(GOAL)
        beta = _wrap(math.atan2(aim[1] - y, aim[0] - x) - h)
        s = np.asarray(obs["sonar"], dtype=np.float64)
        r = float(REFLEX(torch.from_numpy(s[None]), torch.tensor([beta], dtype=torch.float64))[0])
        a = np.float32(r + 0.05 * rng.standard_normal())
        obs, _, terminated, truncated, _ = env.step(np.array([a]))
        sonar.append(s)
        aims.append(aim)
        extra.append(float(a) - r)
        after.append(np.asarray(obs["sonar"], dtype=np.float64))
        poses.append(np.asarray(obs["odometry"], dtype=np.float64))
        done = terminated or truncated
    pose = np.array(poses)
    moved = np.any(pose[1:, :2] != pose[:-1, :2], axis=1)
    return pose, np.array(sonar), np.array(after), np.array(aims), moved, np.array(extra)


def _replayed_reward(delta, pose, sonar, after, aim, moved, extra, step_cost, reactive=True):
    """J of the linearised model, rolled forward with the actions changed by ``delta``
    (``reactive=False``: the recorded actions, not the reflex's response to the new pose)."""
    rays = np.arange(sonar.shape[1]) * (2 * math.pi / sonar.shape[1])
    x, y, th = pose[0]
    total = 0.0
    for t in range(len(aim)):
        shift = np.array((x, y)) - pose[t, :2]
        u = np.stack((np.cos(pose[t, 2] + rays), np.sin(pose[t, 2] + rays)), axis=1)
        seen = np.where(sonar[t] < 1.0, sonar[t] - (u @ shift) / RANGE, sonar[t])
        beta = _wrap(math.atan2(aim[t, 1] - y, aim[t, 0] - x) - th)
        r = float(
            REFLEX(torch.from_numpy(seen[None]), torch.tensor([beta], dtype=torch.float64))[0]
        )
        if not reactive:
            r = pose[t + 1, 2] - pose[t, 2] - extra[t]  # the action the trial took
        th = th + r + extra[t] + delta[t]
        if moved[t]:
            x, y = x + STEP * math.cos(th), y + STEP * math.sin(th)
        total -= abs(_wrap(th - math.atan2(GOAL[1] - y, GOAL[0] - x))) / math.pi
        rim = after[t] * RANGE
        j = int(rim.argmin())
        if rim[j] < CLOSE and moved[t]:
            beam = pose[t + 1, 2] + rays[j]
            nearer = (x - pose[t + 1, 0]) * math.cos(beam) + (y - pose[t + 1, 1]) * math.sin(beam)
            total += -1 + (rim[j] - nearer) / CLOSE
    return total - step_cost / STEP * math.hypot(x - GOAL[0], y - GOAL[1])


def _readings(sonar, after):
    """The record's readings, start to end: each move's readings are the next step's input."""
    assert np.array_equal(sonar[1:], after[:-1])
    return np.concatenate((sonar, after[-1:]))


@pytest.fixture(scope="module")
def trial():
    return _recorded_trial()


def test_the_replayed_model_is_the_recorded_trial(trial):
    pose, sonar, after, aim, moved, extra = trial
    assert len(aim) > 20 and (after * RANGE).min() < CLOSE  # it passes the door: f1 is in play
    # rolled forward with nothing changed, the model retraces the odometry (float32 rounding)
    x, y, th = pose[0]
    for t in range(len(aim)):
        beta = _wrap(math.atan2(aim[t, 1] - y, aim[t, 0] - x) - th)
        r = float(
            REFLEX(torch.from_numpy(sonar[t][None]), torch.tensor([beta], dtype=torch.float64))[0]
        )
        th += r + extra[t]
        if moved[t]:
            x, y = x + STEP * math.cos(th), y + STEP * math.sin(th)
        assert np.allclose((x, y, th), pose[t + 1], atol=1e-5)


@pytest.mark.parametrize("step_cost", [0.0, 0.8])
def test_the_gradient_is_that_of_the_replayed_model(trial, step_cost):
    pose, sonar, after, aim, moved, extra = trial
    held = np.zeros(len(aim), dtype=bool)
    grad = trial_gradient(
        REFLEX, pose, _readings(sonar, after), aim, held, GOAL, STEP, RANGE, CLOSE, step_cost
    )
    h = 1e-6
    for t in (0, 4, 11, 17, len(aim) - 3, len(aim) - 1):
        d = np.zeros(len(aim))
        d[t] = h
        fd = (
            _replayed_reward(d, *trial[:5], extra, step_cost)
            - _replayed_reward(-d, *trial[:5], extra, step_cost)
        ) / (2 * h)
        assert grad[t] == pytest.approx(fd, rel=1e-4, abs=1e-6), t
    # a persistent correction over the first 8 steps: the sum of the step gradients
    d = np.zeros(len(aim))
    d[:8] = h
    fd = (
        _replayed_reward(d, *trial[:5], extra, step_cost)
        - _replayed_reward(-d, *trial[:5], extra, step_cost)
    ) / (2 * h)
    assert grad[:8].sum() == pytest.approx(fd, rel=1e-4)


def test_a_mirrored_trial_has_the_negated_gradient(trial):
    pose, sonar, after, aim, moved, _ = trial
    held = np.zeros(len(aim), dtype=bool)
    held[[3, 9]] = True  # shielded steps are held in both
    n = sonar.shape[1]
    mirror = (-np.arange(n)) % n  # ray k points at heading + k * 15 deg; its mirror at -k
    flip = np.array((1.0, -1.0, -1.0))
    grad = trial_gradient(
        REFLEX, pose, _readings(sonar, after), aim, held, GOAL, STEP, RANGE, CLOSE, 0.5
    )
    mirrored = trial_gradient(
        REFLEX,
        pose * flip,
        _readings(sonar, after)[:, mirror],
        aim * flip[:2],
        held,
        (GOAL[0], -GOAL[1]),
        STEP,
        RANGE,
        CLOSE,
        0.5,
    )
    assert np.allclose(mirrored, -grad, atol=1e-9)
    assert (grad[held] == 0).all() and np.abs(grad).max() > 0.1


def test_heading_left_of_the_goal_in_free_space_the_gradient_turns_right():
    # 10 straight steps 0.3 rad left of the goal's bearing, nothing in sonar range
    n, off = 10, 0.3
    heading = math.atan2(GOAL[1], GOAL[0]) + off
    pose = np.array(
        [
            (k * STEP * math.cos(heading), k * STEP * math.sin(heading), heading)
            for k in range(n + 1)
        ]
    )
    free = np.ones((n + 1, 24))
    aim = np.tile(GOAL, (n, 1))
    grad = trial_gradient(REFLEX, pose, free, aim, np.zeros(n, bool), GOAL, STEP, RANGE, CLOSE)
    assert (grad < 0).all()  # turning right (negative) lowers every later heading error
    assert grad[0] < grad[-1]  # and the earlier the turn, the more steps it helps


def test_reflex_partials_are_its_slopes_and_zero_at_a_jump():
    s = np.ones((2, 24))
    beta = np.array([0.4, -0.4])
    r_beta, r_sonar = reflex_partials(REFLEX, s, beta)
    # free space: the output is d_g-weighted goal following, LEFT = theta/span -> peak * theta/span
    peak, span = REFLEX.config.peaks[0], REFLEX.config.goal_span
    assert np.allclose(r_beta, peak / span) and np.allclose(r_sonar, 0.0)
    # a wall dead ahead, its side picked by the goal's side: at beta = 0 the side flips
    wall = np.ones((1, 24))
    wall[0, [23, 0, 1]] = 0.2 / RANGE
    r_beta, _ = reflex_partials(REFLEX, wall, np.array([0.0]))
    assert r_beta[0] == 0.0


def _partials_of_every_row(reflex, sonar, beta, eps=1e-7, jump=1e-4):
    """reflex_partials written plainly: the reflex on every perturbed row in one call."""
    t, n = sonar.shape
    steps = np.arange(t)
    nearest = [
        np.asarray(rays)[np.argmin(sonar[:, list(rays)], axis=1)]
        for rays in reflex.config.sectors.values()
    ]
    k = 1 + len(nearest)
    s = np.broadcast_to(sonar, (2 * k + 1, t, n)).copy()
    b = np.broadcast_to(beta, (2 * k + 1, t)).copy()
    b[1] += eps
    b[2] -= eps
    for i, ray in enumerate(nearest):
        s[3 + 2 * i, steps, ray] += eps
        s[4 + 2 * i, steps, ray] -= eps
    out = reflex(torch.from_numpy(s.reshape(-1, n)), torch.from_numpy(b.reshape(-1)))
    out = out.numpy().reshape(2 * k + 1, t)
    up, down = out[1::2] - out[0], out[0] - out[2::2]
    slope = np.where(np.maximum(np.abs(up), np.abs(down)) > jump, 0.0, (up + down) / (2 * eps))
    r_sonar = np.zeros((t, n))
    for i, ray in enumerate(nearest):
        r_sonar[steps, ray] += slope[1 + i]
    return slope[0], r_sonar


@pytest.mark.parametrize("scale", [1.0, 0.3, 0.1])
def test_reflex_partials_are_those_of_every_perturbed_row(trial, scale):
    """The partials skip the ray steps that change no membership; they are bit for bit those
    of the reflex on every perturbed row (near walls and far, at many goal angles)."""
    pose, sonar, _, aim, _, _ = trial
    s = np.minimum(sonar * scale, 1.0)
    beta = np.arctan2(aim[:, 1] - pose[:-1, 1], aim[:, 0] - pose[:-1, 0]) - pose[:-1, 2]
    got, want = reflex_partials(REFLEX, s, beta), _partials_of_every_row(REFLEX, s, beta)
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g, w) and np.array_equal(np.signbit(g), np.signbit(w))


def test_reflex_partials_keep_the_bits_of_every_rows_wrapped_angle():
    """torch's atan2 rounds a long batch's vectorised body and its tail differently, so a ray
    step's row may wrap its goal angle to another last bit than its step's unperturbed row:
    the partials keep those rows' own outputs (random readings and angles, many lengths)."""
    rng = np.random.default_rng(0)
    for t in range(20, 60):
        s = np.where(rng.random((t, 24)) < 0.2, rng.uniform(0.01, 0.2, (t, 24)), 1.0)
        beta = rng.uniform(-4.0, 4.0, t)
        got, want = reflex_partials(REFLEX, s, beta), _partials_of_every_row(REFLEX, s, beta)
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w) and np.array_equal(np.signbit(g), np.signbit(w)), t


def test_the_rule_moves_each_neuron_by_at_most_max_step_per_trial():
    # REINFORCE off, so the means move by the trial gradient alone
    base = [
        "run.trials=2",
        "update.beta=0",
        "trial_gradient.max_step=0.01",
        "trial_gradient.limit=0.015",
    ]
    (off,) = train_batch(
        load_config("paper_map", [*base, "trial_gradient.rate=0"]), [3], progress=False
    )
    (on,) = train_batch(
        load_config("paper_map", [*base, "trial_gradient.rate=1"]), [3], progress=False
    )
    assert off.policy.experts.means.abs().max() == 0
    means = on.policy.experts.means
    used = on.policy.experts.count
    assert means.abs().max() <= 0.015 + 1e-12  # the limit
    moved = (means.abs() > 0).sum()
    assert moved > 10 and (means.abs() == 0.015).sum() > 0  # trial 2 pushed some to the limit
    assert int(used.sum()) >= moved
    # trial 1 is the same trial with or without the rule (it acts only after a trial ends)
    first = ("steps", "total_reinforcement", "neurons")
    assert [off.trials[0][k] for k in first] == [on.trials[0][k] for k in first]


def test_absolute_actions_get_the_open_loop_gradient(trial):
    pose, sonar, after, aim, moved, extra = trial
    held = np.zeros(len(aim), dtype=bool)
    grad = trial_gradient(
        REFLEX,
        pose,
        _readings(sonar, after),
        aim,
        held,
        GOAL,
        STEP,
        RANGE,
        CLOSE,
        0.5,
        reactive=False,
    )
    closed = trial_gradient(
        REFLEX, pose, _readings(sonar, after), aim, held, GOAL, STEP, RANGE, CLOSE, 0.5
    )
    assert not np.allclose(grad, closed)  # the reflex's feedback changes the answer
    h = 1e-6
    for t in (0, 9, len(aim) - 2):
        d = np.zeros(len(aim))
        d[t] = h
        fd = (
            _replayed_reward(d, *trial[:5], extra, 0.5, reactive=False)
            - _replayed_reward(-d, *trial[:5], extra, 0.5, reactive=False)
        ) / (2 * h)
        assert grad[t] == pytest.approx(fd, rel=1e-4, abs=1e-6), t
