"""The gradient of a finished trial's reward with respect to each action, through the robot's
own odometry and the reflex: the experts' second actor rule (config section ``trial_gradient``).

Why (docs/journal/learning.md, "The trial gradient"): a one-step perturbation of an action hardly
changes a trial's return, because the reflex steers back at its target on the next steps, so
REINFORCE from 20 noisy trials sees noise. What a *persistent* correction does is known to the
robot, though: its odometry moves exactly as commanded, the heading term f2 of its reward is a
function of the odometry pose, the clearance term f1 a function of its sonar readings, and the
reflex's response to both is a function it computes. Replaying the recorded trial through these
gives dJ/da_t for every action with the reflex's feedback included: a stochastic value gradient
along the real trajectory (Heess et al. 2015, SVG(infinity)), with the noise of the trial held
at what it was.

The model, linearised at the recorded trajectory (s_t = (x, y, theta) the odometry pose, o_t the
sonar readings, l the step length, m_t = 0 when the step collided and was reversed):

    a_t     = R(o_t, beta_t) + e_t              beta_t: bearing of the reflex's target from s_t;
                                                e_t: the correction and the noise (held);
                                                absolute experts: a_t = e_t (no feedback)
    s_{t+1} = (x + m_t l cos(theta + a_t), y + m_t l sin(theta + a_t), theta + a_t)
    o_t     : every beam's hit point stays where it was seen (moving by dp toward it shortens
              the beam by u . dp); a beam at its range sees nothing
    J       = sum_t f1(o_{t+1}) + f2(s_{t+1}) - c |p_T - goal| / l

The last term prices arriving: a final position one step length nearer the goal is one action
fewer, worth ``c``, the trial's mean cost per action times ``step_cost``. Shielded actions are
held (they do not follow the reflex). The costate runs backward once per trial, O(T) 3 x 3
products on floats; the reflex's partials come from one batched call of central differences (it is
piecewise linear). ``tests/learner/test_trial_gradient.py`` checks the result against central
differences of the replayed model.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np
import torch

from symrl.knowledge.reflex import check_finite
from symrl.world.physics import wrap_angle

if TYPE_CHECKING:
    from symrl.knowledge.reflex import FuzzyReflex

__all__ = ["TrialRecord", "reflex_partials", "trial_gradient"]


class TrialRecord:
    """What the update saw of each robot's current trial.

    ``pose`` (B, T + 1, 3) odometry poses and ``sonar`` (B, T + 1, n) readings, from the start
    to after the last move; per transition ``aim`` (B, T, 2) the point the reflex steered at,
    ``held`` (B, T) shielded actions, ``row``/``neuron`` (B, T) the expert row and neuron that
    acted (capacity-free, so growth cannot stale them)."""

    def __init__(self, batch: int, max_steps: int, n_rays: int) -> None:
        self.pose = np.zeros((batch, max_steps + 1, 3))
        self.sonar = np.zeros((batch, max_steps + 1, n_rays))
        self.aim = np.zeros((batch, max_steps, 2))
        self.held = np.zeros((batch, max_steps), dtype=bool)
        self.row = np.zeros((batch, max_steps), dtype=np.int64)
        self.neuron = np.zeros((batch, max_steps), dtype=np.int64)
        self.steps = np.zeros(batch, dtype=np.int64)
        self._rows = np.arange(batch)

    def append(
        self,
        pose: np.ndarray,
        sonar: np.ndarray,
        aim: np.ndarray,
        held: np.ndarray,
        row: np.ndarray,
        neuron: np.ndarray,
        next_pose: np.ndarray,
        next_sonar: np.ndarray,
    ) -> None:
        """One transition of every robot: arrays with the batch first. The next pose and
        readings are the next transition's own (they are written again then), and the last
        transition's end of the trial."""
        rows, t = self._rows, self.steps
        self.pose[rows, t] = pose
        self.pose[rows, t + 1] = next_pose
        self.sonar[rows, t] = sonar
        self.sonar[rows, t + 1] = next_sonar
        self.aim[rows, t] = aim
        self.held[rows, t] = held
        self.row[rows, t] = row
        self.neuron[rows, t] = neuron
        self.steps = t + 1

    def clear(self, rows: np.ndarray) -> None:
        self.steps[rows] = 0


def _bearing_partials(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d atan2(dy, dx) / d(x, y) of the robot's position, with (dx, dy) = target - position."""
    d2 = np.maximum(dx * dx + dy * dy, 1e-12)
    return dy / d2, -dx / d2


@functools.lru_cache(maxsize=8)
def _sector_rays(sectors: tuple[tuple[int, ...], ...]) -> tuple[np.ndarray, bool]:
    """The rays of each sector ``(S, M)`` in the reflex config's order, padded by repeating a
    sector's first ray (the first of equal readings stays the first), and whether no two
    sectors share a ray."""
    width = max(len(r) for r in sectors)
    rays = np.array([[*r, *[r[0]] * (width - len(r))] for r in sectors], dtype=np.intp)
    flat = [ray for r in sectors for ray in r]
    return rays, len(set(flat)) == len(flat)


def reflex_partials(
    reflex: FuzzyReflex,
    sonar: np.ndarray,
    beta: np.ndarray,
    eps: float = 1e-7,
    jump: float = 1e-4,
) -> tuple[np.ndarray, np.ndarray]:
    """dR/d beta (T,) and dR/d sonar (T, n) of the reflex's output at T inputs (float64).

    Central differences in one batched call, on beta and on each sector's nearest ray (the
    only ray of a sector the reflex reads): the reflex is piecewise linear in both, so a step
    of 1e-7 is exact within a piece. Where either side changes by more than ``jump`` (1000 rad
    per unit: no slope of the reflex, a crisp switch of the turning side) the partial is 0: a
    jump is not a slope that a small change of the path can follow.

    A ray's step changes the output only where it changes a sector's NEAR membership: far
    from the walls NEAR is 0 on both sides, the output is the unperturbed one bit for bit and
    the difference 0. So the reflex runs on the unperturbed rows, the beta steps and only those
    ray steps that change a membership (about a third of the rows), from the memberships (the
    reflex reads the sonars only through them)."""
    t, n = sonar.shape
    steps = np.arange(t)
    # the reflex reads each sector's nearest ray: only that ray has a slope
    rays, disjoint = _sector_rays(tuple(tuple(r) for r in reflex.config.sectors.values()))
    n_s = len(rays)
    k = 1 + n_s
    nearest = rays[np.arange(n_s), sonar[:, rays].argmin(axis=2)]  # (T, S)
    # the reflex's own test (it is run below without forward); a step of eps keeps a finite
    # input finite
    check_finite(sonar, beta)
    b = np.repeat(beta[None], 2 * k + 1, axis=0)
    b[1] += eps
    b[2] -= eps
    # the angles wrapped as the reflex wraps the whole batch: their last bit depends on their
    # place in it, so a ray step's row keeps its own
    wrapped = reflex.wrap(torch.from_numpy(b.reshape(-1)))
    # the memberships of the unperturbed sonars and of each sector's ray steps (up, down)
    s = np.repeat(sonar[None], 2 * n_s + 1, axis=0)
    sector = np.arange(n_s)[:, None]
    s[1::2][sector, steps, nearest.T] += eps
    s[2::2][sector, steps, nearest.T] -= eps
    mu = reflex.memberships(s.reshape(-1, n)).reshape(2 * n_s + 1, t, n_s)
    # the ray steps whose memberships or wrapped angle differ from their step's unperturbed ones
    changed = np.any(mu[1:] != mu[0], axis=2) | (wrapped[3 * t :].reshape(-1, t) != wrapped[:t])
    changed = changed.reshape(-1)
    rows = np.concatenate((np.arange(3 * t), 3 * t + np.flatnonzero(changed)))
    some = reflex.from_memberships(
        np.concatenate((mu[0], mu[0], mu[0], mu[1:].reshape(-1, n_s)[changed])), wrapped[rows]
    )
    out = np.repeat(some[None, :t], 2 * k + 1, axis=0)
    out.reshape(-1)[rows] = some
    up, down = out[1::2] - out[0], out[0] - out[2::2]
    jumps = np.maximum(np.abs(up), np.abs(down)) > jump
    slope = np.where(jumps, 0.0, (up + down) / (2 * eps))  # (k, T)
    r_sonar = np.zeros((t, n))
    if disjoint:  # one ray per (step, sector): 0 + slope, as the sum below
        r_sonar[steps[:, None], nearest] += slope[1:].T
    else:
        for i in range(len(rays)):
            r_sonar[steps, nearest[:, i]] += slope[1 + i]
    return slope[0], r_sonar


def trial_gradient(
    reflex: FuzzyReflex,
    pose: np.ndarray,
    sonar: np.ndarray,
    aim: np.ndarray,
    held: np.ndarray,
    goal: tuple[float, float],
    step: float,
    sonar_range: float,
    close: float,
    step_cost: float = 0.0,
    reactive: bool = True,
) -> np.ndarray:
    """dJ/da_t (T,) of one recorded trial (the model of the module docstring).

    ``pose`` (T + 1, 3) the odometry poses and ``sonar`` (T + 1, n) the normalised readings,
    start included; ``aim`` (T, 2); ``held`` (T,); a step that did not translate collided and
    was reversed. ``close`` is d_c of f1 (m); ``step_cost`` the worth of one action fewer.
    Held actions get 0. ``reactive=False``: the actions do not follow the reflex (experts with
    absolute actions, a = p + mu + noise): the open-loop gradient."""
    n = len(aim)
    if n == 0:
        return np.zeros(0)
    moved = np.any(pose[1 : n + 1, :2] != pose[:n, :2], axis=1)
    next_sonar, sonar = sonar[1 : n + 1], sonar[:n]
    rays = sonar.shape[1]
    x, y, th = pose[:n, 0], pose[:n, 1], pose[:n, 2]
    dx, dy = aim[:, 0] - x, aim[:, 1] - y
    beta = wrap_angle(np.arctan2(dy, dx) - th)
    if reactive:
        r_beta, r_sonar = reflex_partials(reflex, sonar, beta)
    else:
        r_beta, r_sonar = np.zeros(n), np.zeros_like(sonar)
    follows = (~held).astype(np.float64)
    # da_t/ds_t = (e0, e1, e2): through the target's bearing, and through the beams' lengths
    # (the three columns as arrays of their own: fewer calls than a (T, 3) array's stacking)
    bx, by = _bearing_partials(dx, dy)
    r_follow = r_beta * follows
    w = r_sonar * follows[:, None] * (sonar < 1.0) / sonar_range  # dR / d(rim metres)
    beams = th[:, None] + np.arange(rays) * (2 * math.pi / rays)
    e0 = r_follow * bx - (w * np.cos(beams)).sum(axis=1)
    e1 = r_follow * by - (w * np.sin(beams)).sum(axis=1)
    e2 = r_follow * -1.0
    # ds_{t+1}/da_t = (d0, d1, 1) at the recorded next heading
    th1 = pose[1 : n + 1, 2]
    ml = np.where(moved, step, 0.0)
    d0, d1 = -ml * np.sin(th1), ml * np.cos(th1)
    # d r_t / d s_{t+1} = (r0, r1, r2): f2 = -|wrap(theta' - psi(p'))| / pi, psi the goal's
    # bearing
    x1, y1 = pose[1 : n + 1, 0], pose[1 : n + 1, 1]
    gx, gy = goal[0] - x1, goal[1] - y1
    px, py = _bearing_partials(gx, gy)
    sign = -np.sign(wrap_angle(th1 - np.arctan2(gy, gx))) / math.pi
    # f1 = -1 + min_j rim_j / d_c below d_c: d f1 / dp = -u_min / d_c (a collision's -3: held)
    rim = next_sonar * sonar_range
    j = rim.argmin(axis=1)
    near = (rim[np.arange(n), j] < close) & moved
    nearest = th1 + j * (2 * math.pi / rays)
    r0 = sign * -px - np.where(near, np.cos(nearest) / close, 0.0)
    r1 = sign * -py - np.where(near, np.sin(nearest) / close, 0.0)
    if step_cost and moved[n - 1]:
        ex, ey = x1[-1] - goal[0], y1[-1] - goal[1]
        d = max(math.hypot(ex, ey), 1e-9)
        r0[n - 1] -= step_cost / step * ex / d
        r1[n - 1] -= step_cost / step * ey / d
    grad = _costate((d0, d1), (e0, e1, e2), (r0, r1, sign))
    out = np.asarray(grad)
    out[held] = 0.0
    return out


def _costate(
    d: tuple[np.ndarray, np.ndarray],
    e: tuple[np.ndarray, np.ndarray, np.ndarray],
    r: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> list[float]:
    """dJ/da_t of every step from d = ds_{t+1}/da_t = (d0, d1, 1), e = da_t/ds_t and
    r = d r_t / d s_{t+1} (each a tuple of (T,) columns)."""
    # the costate lam = dJ(rewards from step t on) / ds_{t+1}, backward on Python floats (a
    # handful of products per step: 3 x 3 numpy calls would cost 10x more). With d = ds_{t+1}/da_t
    # = (d0, d1, 1) and e = da_t/ds_t, ds_{t+1}/ds_t = I + (d0, d1 in the heading column) + d e^T.
    n = len(d[0])
    grad = [0.0] * n
    l0 = l1 = l2 = 0.0
    d0s, d1s = d[0].tolist(), d[1].tolist()
    e0s, e1s, e2s = e[0].tolist(), e[1].tolist(), e[2].tolist()
    r0s, r1s, r2s = r[0].tolist(), r[1].tolist(), r[2].tolist()  # r2 = sign * 1
    for t in range(n - 1, -1, -1):
        l0 += r0s[t]
        l1 += r1s[t]
        l2 += r2s[t]
        xy = l0 * d0s[t] + l1 * d1s[t]
        ld = xy + l2
        grad[t] = ld
        l0, l1, l2 = l0 + ld * e0s[t], l1 + ld * e1s[t], l2 + xy + ld * e2s[t]
    return grad
