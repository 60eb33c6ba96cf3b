"""Sub-goal options per region: a critic that averages trials and an epsilon-greedy actor.

Why this exists (``research/ALGORITHM.md`` sections 3 and 5): the literal learner keeps the best
single trial, so it locks onto lucky reflex trials (trial sd about 3.3), and its new neurons
start from the reflex, which folds into the concave corner. Here the learner *chooses*, once per
region and trial, where the reflex's goal-following input points: at the goal or at one of the
sub-goals that ``symrl.knowledge.subgoals`` derives from the map's region lines (the door).
Obstacle avoidance is untouched. The critic of an option is the mean, over the trials that chose
it, of the return-to-go from the region's first entry (Monte Carlo, so the concave penalty that
lands ~10 actions after the wrong turn is credited to the turn). Averaging, not comparing single
trials, is what makes the choice robust to noise. The module is plain torch (no TorchRL), so the
TorchRL policy and the fast study loop share it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from symrl.knowledge.subgoals import SubgoalConfig, SubgoalTable, build_subgoals
from symrl.world.worldmap import WorldMap

__all__ = ["OptionConfig", "OptionLearner", "OptionSteering", "choice_table"]


@dataclass
class OptionConfig:
    """Actor and critic of the option learner; every default is the tuned value."""

    epsilon: float = 0.3
    """Probability of a uniformly random option at a region's first entry (trial 1)."""

    epsilon_decay: float = 0.8
    """epsilon is multiplied by this after every trial."""

    greedy_after: int = 12
    """From this trial on (1-based count of finished trials) the actor is greedy: the last
    trials show what was learned, not exploration. 0 disables the cut-off."""

    try_untried: bool = True
    """An option never tried yet is chosen before any greedy choice (its critic is unknown)."""

    reach: float = 0.25
    """A sub-goal closer than this (odometry, metres) is reached: the reflex aims at the goal for
    the rest of that region visit (otherwise it would circle the point)."""

    gamma: float = 1.0
    """Discount of the return-to-go (1: the trial's total reinforcement from the entry on)."""

    critic: str = "mean"
    """How an option's trials are summarised: "mean" (the average return-to-go, robust to
    noise) or "best" (the best single return, the literal "keep the best trial" reading, which
    locks onto lucky trials; kept for the ablation)."""

    risk: float = 0.0
    """Greedy choice scores an option by its mean minus ``risk`` times the spread (sd) of its
    returns: rare collisions make an option's returns spread, so risk > 0 prefers the steady
    options. 0: the mean alone."""

    collision_penalty: float = 0.0
    """Extra penalty per collision in the option critic's return only (the reward is unchanged):
    an option seen colliding once drops below the steady ones. 0: the plain return."""

    prior: str = "order"
    """Tie-break among untried/equal options: "order" (table order, goal first) or "random"."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.epsilon <= 1.0:
            raise ValueError(f"OptionConfig.epsilon must be in [0, 1], got {self.epsilon!r}")
        if not 0.0 <= self.epsilon_decay <= 1.0:
            raise ValueError(
                f"OptionConfig.epsilon_decay must be in [0, 1], got {self.epsilon_decay!r}"
            )
        if not isinstance(self.greedy_after, int) or self.greedy_after < 0:
            raise ValueError(
                f"OptionConfig.greedy_after must be an int >= 0, got {self.greedy_after!r}"
            )
        if not (self.reach >= 0.0 and math.isfinite(self.reach)):
            raise ValueError(f"OptionConfig.reach must be a number >= 0, got {self.reach!r}")
        if not (self.collision_penalty >= 0.0 and math.isfinite(self.collision_penalty)):
            raise ValueError(
                f"OptionConfig.collision_penalty must be >= 0, got {self.collision_penalty!r}"
            )
        if not (self.risk >= 0.0 and math.isfinite(self.risk)):
            raise ValueError(f"OptionConfig.risk must be a number >= 0, got {self.risk!r}")
        if not 0.0 < self.gamma <= 1.0:
            raise ValueError(f"OptionConfig.gamma must be in (0, 1], got {self.gamma!r}")
        if self.critic not in ("mean", "best"):
            raise ValueError(f"OptionConfig.critic must be 'mean' or 'best', got {self.critic!r}")
        if self.prior not in ("order", "random"):
            raise ValueError(f"OptionConfig.prior must be 'order' or 'random', got {self.prior!r}")


class OptionLearner:
    """Per-trial option choice per region and the averaged return-to-go critic.

    Use: ``begin_trial()``; every step ``target(region, x, y)`` -> the point the reflex aims at,
    then ``record(reward)``; at the trial's end ``end_trial()``. State (``q``, ``n``) are tensors
    ``(R, K)`` so they can be saved as buffers.
    """

    def __init__(
        self,
        table: SubgoalTable,
        goal: tuple[float, float],
        config: OptionConfig | None = None,
        generator: torch.Generator | None = None,
        q: torch.Tensor | None = None,
        n: torch.Tensor | None = None,
        m2: torch.Tensor | None = None,
    ) -> None:
        self.table = table
        self.goal = (float(goal[0]), float(goal[1]))
        self.config = config or OptionConfig()
        self.generator = generator or torch.Generator().manual_seed(0)
        shape = table.valid.shape
        # q, n may be a module's buffers (saved with a checkpoint); they are updated in place.
        self.q = q if q is not None else torch.zeros(shape, dtype=torch.float64)
        self.n = n if n is not None else torch.zeros(shape, dtype=torch.long)
        # sum of squared deviations of the returns (Welford), for the risk-aware score
        self.m2 = m2 if m2 is not None else torch.zeros(shape, dtype=torch.float64)
        if self.q.shape != shape or self.n.shape != shape:
            raise ValueError(f"OptionLearner: q and n must have shape {tuple(shape)}")
        self.epsilon = self.config.epsilon
        self.trials = 0
        self.begin_trial()

    # --- per trial -------------------------------------------------------------------------

    def begin_trial(self) -> None:
        """Forget this trial's choices; the critic and epsilon carry over."""
        self.choice: dict[int, int] = {}
        self.entry: dict[int, int] = {}
        self.stage = 0
        self.rewards: list[float] = []
        self._region: int | None = None

    def choose(self, region: int, greedy: bool = False) -> int:
        """The option of ``region`` for this trial (chosen at its first entry, then kept);
        ``greedy`` forces the best-critic choice (evaluation)."""
        if region in self.choice:
            return self.choice[region]
        valid = self.table.valid[region]
        options = torch.nonzero(valid).flatten()
        after = self.config.greedy_after
        greedy_only = greedy or bool(after and self.trials >= after)
        untried = options[self.n[region, options] == 0]
        if self.config.try_untried and not greedy_only and untried.numel() > 0:
            option = self._pick(untried)
        elif not greedy_only and self._uniform() < self.epsilon:
            option = int(options[self._randint(options.numel())])
        else:
            q = torch.where(self.n[region] > 0, self.score(region), -math.inf)
            q = torch.where(valid, q, -math.inf)
            if bool(torch.isinf(q).all()):
                option = self._pick(options)
            else:
                option = self._pick(torch.nonzero(q == q.max()).flatten())
        self.choice[region] = option
        self.entry[region] = len(self.rewards)
        return option

    def target(self, region: int, x: float, y: float, greedy: bool = False) -> tuple[float, float]:
        """The point the reflex should aim at from odometry ``(x, y)`` in ``region``."""
        if region != self._region:
            self.stage = 0  # a new visit aims at the sub-goal again
            self._region = region
        option = self.choose(region, greedy)
        # stage 0: the option's point; 1: its follow-up through the passage; 2: the goal
        while self.stage < 2:
            if self.stage == 0:
                point = self.table.point(region, option)
            else:
                point = self.table.then_point(region, option)
                if point is None:
                    break
            if math.hypot(point[0] - x, point[1] - y) >= self.config.reach:
                return point
            self.stage += 1
        self.stage = 2
        return self.goal

    def record(self, reward: float, collision: bool = False) -> None:
        """The reinforcement of the step just taken (and whether it was a collision)."""
        penalty = self.config.collision_penalty if collision else 0.0
        self.rewards.append(float(reward) - penalty)

    def end_trial(self) -> dict[str, float]:
        """Update each chosen option's critic with the return-to-go from its region's first
        entry, decay epsilon, and start a new trial. Returns diagnostics."""
        g = self.config.gamma
        for region, option in self.choice.items():
            tail = self.rewards[self.entry[region] :]
            ret = sum(r * g**t for t, r in enumerate(tail))
            self.n[region, option] += 1
            count = int(self.n[region, option])
            if self.config.critic == "best":
                if count == 1 or ret > float(self.q[region, option]):
                    self.q[region, option] = ret
            else:
                old = float(self.q[region, option])
                self.q[region, option] += (ret - old) / count
                self.m2[region, option] += (ret - old) * (ret - float(self.q[region, option]))
        self.trials += 1
        self.epsilon *= self.config.epsilon_decay
        out = {"epsilon": self.epsilon}
        names = self.table.region_names
        out.update({f"option_{names[r]}": float(o) for r, o in self.choice.items()})
        self.begin_trial()
        return out

    # --- helpers -----------------------------------------------------------------------------

    def score(self, region: int) -> torch.Tensor:
        """Greedy score of every option of ``region``: mean - risk * sd of its returns."""
        if self.config.risk == 0.0:
            return self.q[region]
        n = self.n[region].clamp_min(1).to(torch.float64)
        sd = (self.m2[region] / n).clamp_min(0.0).sqrt()
        return self.q[region] - self.config.risk * sd

    def greedy(self) -> list[int]:
        """The option each region would choose greedily now (-1 if none tried)."""
        scores = torch.stack([self.score(r) for r in range(self.q.shape[0])])
        q = torch.where((self.n > 0) & self.table.valid, scores, -math.inf)
        best = q.argmax(dim=1)
        return [int(b) if bool(torch.isfinite(q[r, b])) else -1 for r, b in enumerate(best)]

    def _uniform(self) -> float:
        return float(torch.rand((), generator=self.generator, dtype=torch.float64))

    def _randint(self, n: int) -> int:
        return int(torch.randint(n, (), generator=self.generator))

    def _pick(self, candidates: torch.Tensor) -> int:
        if self.config.prior == "random":
            return int(candidates[self._randint(candidates.numel())])
        return int(candidates[0])


def choice_table(region_names: tuple[str, ...], labels: list[str]) -> SubgoalTable:
    """A table of the same non-spatial choices in every region (its points are unused): lets
    :class:`OptionLearner` choose any per-region setting by the same rules as sub-goals."""
    r, k = len(region_names), len(labels)
    return SubgoalTable(
        region_names, torch.zeros(r, k, 2), torch.ones(r, k, dtype=torch.bool), [labels] * r
    )


class OptionSteering(nn.Module):
    """What the policy holds when ``learner.options`` is on: the map's sub-goal table, the option
    learner, and the angle the reflex's goal following should steer toward; with
    ``avoidance`` values also a second learner choosing the reflex's avoidance desirability
    d_a per region (:meth:`avoidance`), on the same returns.

    The critics (``q``, ``n``, ...) are buffers, so they are saved and loaded with the policy."""

    q: torch.Tensor
    n: torch.Tensor

    def __init__(
        self,
        world: WorldMap,
        config: OptionConfig | None = None,
        subgoals: SubgoalConfig | None = None,
        seed: int = 0,
        avoidance: list[float] | tuple[float, ...] = (),
    ) -> None:
        super().__init__()
        self.table = build_subgoals(world, subgoals)
        shape = self.table.valid.shape
        self.register_buffer("q", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("n", torch.zeros(shape, dtype=torch.long))
        self.register_buffer("m2", torch.zeros(shape, dtype=torch.float64))
        generator = torch.Generator().manual_seed(int(seed) + 7919)  # own stream, not the neurons'
        goal = (world.goal.x, world.goal.y)
        self.learner = OptionLearner(
            self.table, goal, config, generator, q=self.q, n=self.n, m2=self.m2
        )
        self.avoidance_values = tuple(float(v) for v in avoidance)
        self.avoid_learner: OptionLearner | None = None
        if self.avoidance_values:
            labels = [f"d_a={v:g}" for v in self.avoidance_values]
            avoid_table = choice_table(self.table.region_names, labels)
            ashape = avoid_table.valid.shape
            self.register_buffer("avoid_q", torch.zeros(ashape, dtype=torch.float64))
            self.register_buffer("avoid_n", torch.zeros(ashape, dtype=torch.long))
            self.register_buffer("avoid_m2", torch.zeros(ashape, dtype=torch.float64))
            self.avoid_learner = OptionLearner(
                avoid_table,
                goal,
                config,
                torch.Generator().manual_seed(int(seed) + 15485863),
                q=self.avoid_q,
                n=self.avoid_n,
                m2=self.avoid_m2,
            )

    @classmethod
    def from_learner_config(cls, lc: object, world: WorldMap, seed: int = 0) -> OptionSteering:
        """Build from a ``LearnerConfig`` (its ``option_*`` and ``subgoal_*`` fields)."""
        config = OptionConfig(
            epsilon=lc.option_epsilon,
            epsilon_decay=lc.option_epsilon_decay,
            greedy_after=lc.option_greedy_after,
            try_untried=lc.option_try_untried,
            reach=lc.option_reach,
            critic=lc.option_critic,
            risk=lc.option_risk,
            collision_penalty=lc.option_collision_penalty,
        )
        subgoals = SubgoalConfig(
            past=lc.subgoal_past,
            beyond=(0.0, 0.4) if lc.subgoal_on_line else (0.4,),
            min_clearance=lc.subgoal_min_clearance,
        )
        return cls(world, config, subgoals, seed, avoidance=lc.option_avoidance)

    def angle(self, region: int, odometry: tuple[float, float, float], greedy: bool) -> float:
        """Signed angle (left positive) from the odometry heading to this region's target."""
        x, y, heading = odometry
        tx, ty = self.learner.target(region, x, y, greedy)
        return math.remainder(math.atan2(ty - y, tx - x) - heading, 2.0 * math.pi)

    def avoidance(self, region: int, greedy: bool) -> int | None:
        """Index into ``avoidance_values`` chosen for ``region`` this trial (None: off)."""
        if self.avoid_learner is None:
            return None
        return self.avoid_learner.choose(region, greedy)

    def record(self, reward: float, collision: bool = False) -> None:
        self.learner.record(reward, collision)
        if self.avoid_learner is not None:
            self.avoid_learner.record(reward, collision)

    def end_trial(self) -> dict[str, float]:
        out = self.learner.end_trial()
        if self.avoid_learner is not None:
            for key, value in self.avoid_learner.end_trial().items():
                if key.startswith("option_"):  # the d_a chosen per region, by value
                    out["avoid_" + key[7:]] = self.avoidance_values[int(value)]
        return out

    def _load_from_state_dict(self, *args, **kwargs) -> None:  # type: ignore[override]
        super()._load_from_state_dict(*args, **kwargs)
        self.learner.q, self.learner.n, self.learner.m2 = (
            self.q,
            self.n,
            self.m2,
        )  # copy_ keeps them shared; be explicit
        if self.avoid_learner is not None:
            learner = self.avoid_learner
            learner.q, learner.n, learner.m2 = self.avoid_q, self.avoid_n, self.avoid_m2
