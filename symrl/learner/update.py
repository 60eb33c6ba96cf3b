"""The TESEO update (paper 8.3): it learns, the policy acts.

Per transition (s, a, r, s') of every robot of the batch, on the neuron i that chose a (grown
first if the policy met a novel state at s, with p = the policy's ``proto``, u = r(s)):

    delta = r + gamma * u' - u_i        u' = 0 if s' is terminal; r if s' is novel (the utility
                                        its new neuron will get); else the utility of its winner
    |delta| > theta:  grow a neuron at x (p = proto, u = u_i + delta, mu = 0)   error-driven
    else:             u_i  += eta * delta                                       TD(0)
                      mu_i += beta * delta * (xi - mu_i)                        REINFORCE
                      c_i  += kappa * (x - c_i)   if delta > 0                  centre shift

The paper adapts the previous winner *before* acting on the present sensation: TorchRL's loop
gives that order (the update of a transition runs before the policy acts on its next state), so
no state is handed between the two. What the robot makes of s' (its expert and input x, the
pose it believes) is read from ``"next"``, where the perception transform wrote it. The steps
are the gradient steps of 1/2 delta^2 (target detached, lr eta) and of
-delta * log N(xi; mu, sigma^2) (lr beta * sigma^2);
``tests/learner/test_update.py`` checks them against autograd. Growth replaces rows, which an
optimizer cannot follow, so they are applied in place under ``no_grad``. It is no TorchRL
``LossModule``: there is no loss to differentiate, and no optimizer steps it.

End of a robot's trial (:meth:`end_trial`, called by the loop for the robots whose trial
ended; it returns the temperature each trial explored with, as the trial's record shows it):
after a goal-reaching trial whose total beats every earlier successful one, each neuron used
gets p <- the action it took and mu <- 0; with ``trial_gradient.rate`` > 0, each neuron's mu
steps along the trial's reward gradient (``symrl.learner.trial_gradient``); then
T <- max(T_min, cooling * T); with options, the critic of each option chosen in the trial steps
toward its return-to-go from the region's first entry.

What the update changes across trials lives in modules the policy holds and hands over at
construction: the experts, ``policy.progress`` (temperature, best total, trials done), the
options' ``critic`` and crossings; the update changes them only through their own methods
(``experts.add_np``, ``experts.learn``, ``progress.cool``, ``critic.learn``, ...). Its own state
is the returns of the trials in progress (:class:`symrl.learner.returns.TrialReturns`), saved
as :meth:`TeseoUpdate.state_dict`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase

from symrl.fastpaths import new_tensordict, read
from symrl.grad import no_grad
from symrl.learner.config import TrialGradientConfig, UpdateConfig
from symrl.learner.policy import MixtureOfExpertsPolicy
from symrl.learner.returns import TrialReturns
from symrl.learner.trial_gradient import TrialRecord, trial_gradient
from symrl.world.robot import RobotConfig

__all__ = ["TeseoUpdate", "UpdateKeys"]


@dataclass(frozen=True)
class UpdateKeys:
    """Keys the update reads; change them with :meth:`TeseoUpdate.set_keys`."""

    expert: str = "expert"
    winner: str = "winner"
    novel: str = "novel"
    x: str = "x"
    proto: str = "proto"
    xi: str = "xi"
    taken: str = "taken"
    region: str = "region"
    aim: str = "aim"
    shielded: str = "shielded"
    option_entry: str = "option_entry"
    wall_follow: str = "wall_follow"
    option_border: str = "option_border"
    state_reward: str = "state_reward"
    sonar: str = "sonar"
    pose: str = "pose"
    reward: str = "reward"
    done: str = "done"
    terminated: str = "terminated"
    truncated: str = "truncated"


class TeseoUpdate:
    """Online per-transition update of a :class:`MixtureOfExpertsPolicy` (no optimizer).

    Calling it on a batch [B] of transitions (one per robot) updates every robot's previous
    winner and returns a TensorDict of diagnostics (``td_error``, ``grown``, ``neurons``);
    :meth:`end_trial` closes the trials of some robots and returns a TensorDict of what it did
    (``replaced``, ``improved``, ``best_total``, ``temperature``, one row per robot closed).
    The keys it reads are renamed with :meth:`set_keys`. A plain object: the policy and its
    parts are saved with the policy, the update's own state is :attr:`returns`.
    """

    out_keys = ["td_error", "grown", "neurons"]

    def __init__(
        self,
        policy: MixtureOfExpertsPolicy,
        update: UpdateConfig,
        trial_gradient: TrialGradientConfig,
        robot: RobotConfig,
        max_actions: int,
    ) -> None:
        """The update of ``policy``'s experts with the config sections ``update`` and
        ``trial_gradient``, for a robot ``robot`` (``env.robot``) whose trials last at most
        ``max_actions`` actions (``env.max_actions``, the world's step budget applied). Build
        it with :func:`symrl.assembly.build_update`."""
        self.policy = policy
        self.settings = update
        self.gradient = trial_gradient
        self.robot = robot
        self.learning = policy.experts_config.learning
        self.novelty_radius = policy.experts_config.novelty_radius
        # the modules the policy hands over (saved with it)
        self.experts = policy.experts
        self.progress = policy.progress
        self.options = policy.options
        self.critic = policy.options.critic if policy.options is not None else None
        self.crossings = policy.options.crossings if policy.options is not None else None
        self.tensor_keys = UpdateKeys()
        batch = policy.batch
        # option critics: the return so far in the trial, at each region's first entry and,
        # with crossings, at every choice of a trial (a region's first, and each after an
        # option was given up), credited with the return-to-go from it
        choices = None
        if policy.options is not None and self.crossings is not None:
            choices = policy.options.valid.shape[1]
        keep_first = self.critic is not None and self.critic.credit == "first"
        self.returns = TrialReturns(batch, len(policy.region_names), choices, keep_first)
        # the record of the trials in progress for the trial gradient and the remembered way
        # (empty at every trial boundary, where runs are saved, so it is not part of the state)
        self.record: TrialRecord | None = None
        self._gradient_on = trial_gradient.rate > 0 and self.learning
        options = policy.options
        way = options.remembered_way if options is not None else None
        arrivals = options.goal_scans if options is not None else None
        if self._gradient_on or way is not None or arrivals is not None:
            rays = policy.reflex.config.n_rays
            self.record = TrialRecord(batch, max_actions, rays)

    @property
    def in_keys(self) -> list:
        k = self.tensor_keys
        own = [
            k.expert,
            k.winner,
            k.novel,
            k.x,
            k.proto,
            k.xi,
            k.taken,
            k.region,
            k.option_entry,
            k.state_reward,
        ]
        reached = [k.expert, k.x, k.reward, k.terminated, k.truncated]
        if self.crossings is not None:
            own += [k.wall_follow, k.option_border]
        if self.record is not None:
            own += [k.sonar, k.pose, k.aim, k.shielded]
            reached += [k.sonar, k.pose]
        return own + [("next", key) for key in reached]

    def set_keys(self, **renamed: str) -> None:
        """Read other keys than :class:`UpdateKeys`' defaults (``set_keys(xi="noise")``)."""
        known = {f.name for f in fields(UpdateKeys)}
        for key in renamed:
            if key not in known:
                raise ValueError(
                    f"{key!r} is not an accepted tensordict key for the update "
                    f"(accepted: {sorted(known)})"
                )
        self.tensor_keys = replace(self.tensor_keys, **renamed)

    def state_dict(self) -> dict[str, torch.Tensor]:
        """The update's own state (the returns of the trials in progress)."""
        return self.returns.state_dict()

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.returns.load_state_dict(state)

    def __call__(self, td: TensorDictBase) -> TensorDictBase:
        return self.forward(td)

    @no_grad
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        """Update every robot's previous winner from its transition (batch [B]).

        The arithmetic runs in numpy on the tensors' memory: the batch is a handful of numbers
        and a numpy call costs a fraction of a torch op's dispatch (the update took about a
        third of the loop's time in torch ops, ``benchmarks/bench_train.py``). Every step is an
        exactly rounded IEEE operation in the same order as the formulas, so the numbers are
        those of the torch version; the centre shift stays a torch ``lerp``."""
        k = self.tensor_keys
        batch = self.policy.batch
        nxt = read(td, "next")
        r = self._returns(td, nxt)
        if not self.learning:
            if self.record is not None:  # the remembered way's poses and scans (no neuron)
                none = np.zeros(batch, dtype=np.int64)
                self._record(td, nxt, none, none)
            zero = torch.zeros(batch, dtype=torch.float64)
            return TensorDict(
                td_error=zero,
                grown=torch.zeros(batch, dtype=torch.long),
                neurons=self.policy.neurons().sum(-1),
                batch_size=[batch],
            )
        bank = self.experts
        expert, winner = read(td, k.expert).numpy(), read(td, k.winner).numpy()
        x, proto = read(td, k.x).numpy(), read(td, k.proto).numpy()
        grown = np.zeros(batch, dtype=np.int64)

        # 1. the neuron the policy acted as at a novel state is born now
        novel = read(td, k.novel).numpy()
        if novel.any():
            new = np.flatnonzero(novel)
            u0 = read(td, k.state_reward).numpy().reshape(-1)[new]
            winner = winner.copy()
            winner[new] = bank.add_np(new, expert[new], x[new], proto[new], u0)
            grown += novel
        # flat views of the storage, taken after any growth (the capacity may have doubled)
        flat = bank.flat
        index = bank.flat_index_np(expert, winner)
        bank.mark_taken(index, read(td, k.taken).numpy())
        if self.record is not None:
            self._record(td, nxt, flat.row_base + expert, winner)

        # 2. the utility of the state reached
        u_prev = flat.utilities[index]
        u_next = self._next_utility(nxt, r, u_prev, flat.utilities)

        # 3. TD error; error-driven growth or the TD / REINFORCE / centre steps
        update = self.settings
        delta = r + update.gamma * u_next - u_prev
        split = np.abs(delta) > update.error_threshold
        if split.any():
            s = np.flatnonzero(split)
            bank.add_np(s, expert[s], x[s], proto[s], (u_prev + delta)[s])
            grown += split
            index = bank.flat_index_np(expert, winner)  # the capacity may have doubled
        # TD(0) and REINFORCE on the rows that did not split (a split row keeps its values),
        # the centre shift where the error is positive
        step = np.where(split, 0.0, delta)
        bank.learn(
            index,
            u_prev,
            step,
            read(td, k.xi).numpy(),
            x,
            ~split & (delta > 0),
            (update.eta, update.beta, update.kappa),
        )
        return new_tensordict(
            {
                "td_error": torch.from_numpy(delta),
                "grown": torch.from_numpy(grown),
                "neurons": torch.from_numpy(bank.flat.counts.reshape(batch, -1).sum(-1)),
            },
            torch.Size([batch]),
        )

    def _returns(self, td: TensorDictBase, nxt: TensorDictBase) -> np.ndarray:
        """The transition's rewards (B,) float64, added to the returns of the trials in
        progress (with options: from each region's first entry; with crossings: the crossing
        evidence too)."""
        k = self.tensor_keys
        r = read(nxt, k.reward).numpy().reshape(self.policy.batch).astype(np.float64)
        if self.options is not None:
            entered = read(td, k.option_entry).numpy()
            if entered.any():
                option = read(td, "option").numpy() if self.crossings is not None else None
                self.returns.enter(np.flatnonzero(entered), read(td, k.region).numpy(), option)
        self.returns.add(r)
        if self.crossings is not None:
            self._observe_crossings(td, nxt)
        return r

    def _record(
        self, td: TensorDictBase, nxt: TensorDictBase, row: np.ndarray, winner: np.ndarray
    ) -> None:
        """The step in the trial gradient's record: the poses the robot steered by (its
        belief), its sonars, aim, shield and the neuron that acted (storage row, index)."""
        k, record = self.tensor_keys, self.record
        assert record is not None
        record.append(
            read(td, k.pose).numpy(),
            read(td, k.sonar).numpy(),
            read(td, k.aim).numpy(),
            read(td, k.shielded).numpy(),
            row,
            winner,
            read(nxt, k.pose).numpy(),
            read(nxt, k.sonar).numpy(),
        )

    def _next_utility(
        self, nxt: TensorDictBase, r: np.ndarray, u_prev: np.ndarray, utilities: np.ndarray
    ) -> np.ndarray:
        """u' of the state reached, as the robot perceives it (its perception transform's
        keys): 0 if terminal; r if novel (its new neuron's utility); else its winner's; a
        truncated trial bootstraps from the nearest neuron (no growth: the trial is over)."""
        k, bank = self.tensor_keys, self.experts
        terminated = read(nxt, k.terminated).numpy().reshape(-1)
        truncated = read(nxt, k.truncated).numpy().reshape(-1)
        seen_expert = read(nxt, k.expert).numpy()
        seen_winner, distance = bank.nearest_np(seen_expert, read(nxt, k.x).numpy())
        seen_novel = distance > self.novelty_radius  # inf for an empty expert
        u_seen = utilities[bank.flat_index_np(seen_expert, np.maximum(seen_winner, 0))]
        u_trunc = np.where(seen_winner >= 0, u_seen, u_prev)
        u_next = np.where(seen_novel, r, u_seen)
        u_next = np.where(truncated, u_trunc, u_next)
        u_next[terminated] = 0.0
        return u_next

    def _observe_crossings(self, td: TensorDictBase, nxt: TensorDictBase) -> None:
        """The crossing evidence of the state reached (and of a trial's first state): the
        sonar rays from the believed pose, and where the robot crossed a border."""
        k, crossings, policy = self.tensor_keys, self.crossings, self.policy
        assert crossings is not None
        scale = self.robot.sonar_range
        pose = read(td, k.pose).numpy().astype(np.float64)
        pose_next = read(nxt, k.pose).numpy().astype(np.float64)
        region, region_next = read(td, k.region).numpy(), read(nxt, k.region).numpy()
        first = read(td, "is_init", None)
        if first is not None and first.any():
            rows = np.flatnonzero(first.numpy().reshape(-1))
            sonar = read(td, k.sonar).numpy()[rows].astype(np.float64) * scale
            crossings.observe_rows(rows, pose[rows], sonar, region[rows])
        sonar_next = read(nxt, k.sonar).numpy().astype(np.float64) * scale
        crossings.observe(pose_next, sonar_next, region_next)
        following = read(td, k.wall_follow, None)
        if following is not None:
            crossings.watch(following.numpy().reshape(-1), read(td, k.option_border).numpy())
        moved = region != region_next
        if moved.any():
            names = policy.region_names
            for b in np.flatnonzero(moved).tolist():
                crossings.cross(
                    b,
                    names[int(region[b])],
                    names[int(region_next[b])],
                    pose[b, :2],
                    pose_next[b, :2],
                )

    @no_grad
    def end_trial(
        self, rows: torch.Tensor, totals: torch.Tensor, reached: torch.Tensor
    ) -> TensorDictBase:
        """Close the trials of robots ``rows`` (k,) (their totals (k,) and whether they reached
        the goal (k,) bool): action replacement after a better success, the trial gradient,
        cooling, the option critics, the trial count. Returns a TensorDict of batch [k]:
        ``replaced`` (neurons replaced per row), ``improved`` (a better success),
        ``best_total`` (the best success so far) and ``temperature`` (the one the trial
        explored with, before this call cools it)."""
        update, progress = self.settings, self.progress
        if self.record is not None:  # from the record, cleared at the end of this call
            self._learn_arrivals(rows.numpy(), reached.numpy())
            self._learn_way(rows.numpy(), reached.numpy())
        # numpy on the buffers' memory (a handful of rows), the same operations
        rows_np, n = rows.numpy(), rows.shape[0]
        explored = progress.temperatures(rows_np)
        totals_np = totals.numpy().astype(np.float64)
        replaced = np.zeros(n, dtype=np.int64)
        improved = np.zeros(n, dtype=bool)
        if self.learning:
            improved = progress.improve(rows_np, totals_np, reached.numpy())
            if update.replace_actions and improved.any():
                better = torch.from_numpy(rows_np[improved])
                replaced[improved] = self.experts.replace_actions(better).numpy()
            progress.cool(rows_np, update.cooling, update.temperature_min)
            if self._gradient_on:
                self._trial_gradient_step(rows_np)
            self.experts.clear_trial(rows)
        if self.critic is not None and self.crossings is not None:
            self.critic.learn_choices(*self.returns.close_choices(rows_np))
            self.critic.end_trials(rows_np)
        elif self.critic is not None:
            assert self.options is not None
            returns = self.returns.close_entries(rows_np)
            self.critic.learn(rows_np, self.options.trial_choices(rows_np), returns)
        if self.critic is not None and self.critic.tracks_shortest:
            assert self.options is not None
            steps = self.options.trial_steps(rows_np).astype(np.float64)
            self.critic.finish(rows_np, steps, reached.numpy().astype(bool))
        self.returns.close(rows_np)
        if self.record is not None:
            self.record.clear(rows_np)
        progress.count(rows_np)
        best = progress.best_totals(rows_np)
        return new_tensordict(
            {
                "replaced": torch.from_numpy(replaced),
                "improved": torch.from_numpy(improved),
                "best_total": torch.from_numpy(best),
                "temperature": torch.from_numpy(explored),
            },
            torch.Size([n]),
        )

    def _learn_arrivals(self, rows: np.ndarray, reached: np.ndarray) -> None:
        """Where each of the finished trials of ``rows`` that reached the goal (``reached``
        (k,) bool) arrived, for the goal scans (options with ``goal_scans``), from the record:
        the last pose and scan."""
        arrivals = self.options.goal_scans if self.options is not None else None
        rec = self.record
        if arrivals is None or rec is None:
            return
        for b in rows[reached].tolist():
            n = int(rec.steps[b])
            arrivals.learn(b, rec.pose[b, n], rec.sonar[b, n])

    def _learn_way(self, rows: np.ndarray, reached: np.ndarray) -> None:
        """The finished trials of ``rows`` (``reached`` (k,) bool) for the remembered way
        (options with ``remembered_way``), from the record."""
        way = self.options.remembered_way if self.options is not None else None
        rec = self.record
        if way is None or rec is None:
            return
        assert self.options is not None
        choices = self.options.trial_choices(rows)
        first = self.options.trial_first_choices(rows)
        scans = self.options.goal_scans
        searched = scans.passed[rows] if scans is not None else np.zeros(len(rows), dtype=bool)
        for k, (b, ok) in enumerate(zip(rows.tolist(), reached.tolist(), strict=True)):
            n = int(rec.steps[b])
            pose, sonar = rec.pose[b, : n + 1], rec.sonar[b, : n + 1]
            way.learn(
                b, pose, sonar, choices[k], bool(ok), first=first[k], goal_searched=searched[k]
            )

    def _trial_gradient_step(self, rows: np.ndarray) -> None:
        """mu_j += clip(rate * sum of dJ/da_t over the steps neuron j acted, +-max_step), kept
        within +-limit, for every neuron that acted in the finished trials of ``rows``."""
        rec, policy = self.record, self.policy
        assert rec is not None
        tg, robot = self.gradient, self.robot
        goal = policy.knowledge.goal
        flat = self.experts.flat
        returns = self.returns.so_far()
        for b in rows.tolist():
            n = int(rec.steps[b])
            if n == 0:
                continue
            # the price of one action more: the trial's own mean cost per action
            cost = tg.step_cost * max(-float(returns[b]), 0.0) / n
            grad = trial_gradient(
                policy.reflex,
                rec.pose[b, : n + 1],
                rec.sonar[b, : n + 1],
                rec.aim[b, :n],
                rec.held[b, :n],
                (goal.x, goal.y),
                robot.step,
                robot.sonar_range,
                robot.close_distance,
                cost,
                reactive=policy.experts_config.residual,
            )
            index = rec.row[b, :n] * flat.capacity + rec.neuron[b, :n]
            # per neuron, its steps' sum in the steps' order (bincount's), read at the neurons
            # that acted; clipped by min/max (np.unique and np.clip cost several times as much
            # on a trial's ~30 steps)
            used = np.flatnonzero(np.bincount(index))
            total = np.bincount(index, weights=grad)[used]
            step = np.minimum(np.maximum(tg.rate * total, -tg.max_step), tg.max_step)
            self.experts.step_means(used, step, tg.limit)

    def __repr__(self) -> str:
        u = self.settings
        return (
            f"{type(self).__name__}(gamma={u.gamma}, eta={u.eta}, beta={u.beta}, "
            f"kappa={u.kappa}, theta={u.error_threshold})"
        )
