"""The mixture-of-experts controller (paper Fig. 4, sections 6-8): gate, expert, winner, action.

Per step (``research/ALGORITHM.md`` section 1, steps 1-5 and 7-8):

1. x = (24 normalised sonars, 8 goal-distance codes phi_m = exp(-((mu_m - rho) / w)^2)), rho the
   odometry distance to the goal over the start's distance, clipped to [0, 1];
2. the region gate (the map's symbolic rules on the odometry pose) picks one expert (always the
   same one without partition);
3. the nearest neuron wins; if there is none within the novelty radius, a neuron is grown at x
   with the reflex's action (or a random one without reflex) and utility r(state);
4. sigma = T / (1 + e^u), xi ~ N(mu, sigma^2), action = clip(p + xi, -pi, pi);
5. with ``learner.shield`` the IR shield replaces an action whose move would graze a wall by
   the nearest safe angle (the neuron remembers the action actually taken).

With TorchRL's exploration type DETERMINISTIC / MODE / MEAN the policy is greedy and read-only:
action = clip(p + mu, -pi, pi); a situation no neuron covers gets the action a new neuron would
get, without storing it.

Learning happens in :class:`symrl.learner.loss.TeseoLoss`. Because TESEO adapts the previous
winner *before* acting on the present sensation (paper 8.3), the loss perceives the next state
(winner search and growth) while updating, and hands that perception to this policy with
:meth:`hold`; the next :meth:`forward` reuses it instead of searching again.

Seams for variants (issue #4): :meth:`reflex_target` (the angle the reflex steers toward),
:meth:`new_neuron_action`, :meth:`initial_utility`, :meth:`end_trial`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torch import nn
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs.utils import ExplorationType, exploration_type

from symrl.knowledge.reflex import FuzzyReflex, ReflexConfig
from symrl.knowledge.regions import RegionMapper
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.learner.config import LearnerConfig
from symrl.learner.experts import GrowingRBFExpert
from symrl.learner.options import OptionSteering
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap, load_map

__all__ = ["Observation", "Perception", "MixtureOfExpertsPolicy", "OBS_KEYS"]

OBS_KEYS = ("sonar", "ir", "bumper", "odometry", "goal")
_GREEDY = (ExplorationType.DETERMINISTIC, ExplorationType.MODE, ExplorationType.MEAN)
_PI = math.pi
_NOISE_BLOCK = 4096  # normal draws per refill: one torch call instead of one per step


class Observation(NamedTuple):
    """One unbatched observation, as the env gives it (see ARCHITECTURE.md)."""

    sonar: torch.Tensor
    ir: torch.Tensor
    bumper: torch.Tensor
    odometry: torch.Tensor
    goal: torch.Tensor

    @classmethod
    def from_td(cls, td: TensorDictBase, prefix: tuple[str, ...] = (), index: int | None = None):
        """Read the five columns once (``index`` picks a row of a batched transition)."""
        if index is None:
            return cls(*(td.get((*prefix, k)) for k in OBS_KEYS))
        return cls(*(td.get((*prefix, k))[index] for k in OBS_KEYS))


class Perception(NamedTuple):
    """What the gate and the winner search made of one observation."""

    region: int
    """Map region id of the odometry pose (order of the map's region names)."""
    expert: int
    """Index of the expert that handles it (= region with partition, else 0)."""
    winner: int
    """Winning neuron in that expert (-1 if none)."""
    novel: bool
    """No neuron within the novelty radius (before any growth)."""
    grown: bool
    """A neuron was grown for it (then ``winner`` is the new neuron)."""
    x: torch.Tensor
    """The 32-value input."""
    odometry: tuple[float, float, float]
    """The pose it was computed from (to check a held perception matches the next call)."""


class MixtureOfExpertsPolicy(TensorDictModuleBase):
    """Region-gated growing RBF experts acting through Gullapalli's Gaussian unit (Eq. 6).

    Reads the observation keys (``sonar``, ``ir``, ``bumper``, ``odometry``, ``goal``) of an
    unbatched tensordict and writes (``spec`` describes them): ``action`` (1,) float32 in
    [-pi, pi]; ``region`` (map region id), ``expert`` (expert index), ``winner`` (neuron index,
    -1 if none) as long scalars; ``x`` (32,) the input; ``xi`` and ``sigma`` the exploration
    draw and its std (0 when greedy); ``grown`` whether a neuron was grown for this state;
    ``shielded`` whether the IR shield replaced the action.
    """

    in_keys = list(OBS_KEYS)
    out_keys = ["action", "region", "expert", "winner", "x", "xi", "sigma", "grown", "shielded"]

    temperature: torch.Tensor
    best_total: torch.Tensor
    trials_done: torch.Tensor

    def __init__(
        self,
        config: LearnerConfig | None = None,
        world: WorldMap | str = "hailu2001",
        robot: RobotConfig | None = None,
        reflex: FuzzyReflex | None = None,
        seed: int = 0,
    ) -> None:
        super().__init__()
        self.config = config = config if config is not None else LearnerConfig()
        self.world = world if isinstance(world, WorldMap) else load_map(world)
        self.robot = robot if robot is not None else RobotConfig()
        self.reflex = reflex if reflex is not None else FuzzyReflex(ReflexConfig())
        self.mapper = RegionMapper.from_map(self.world)
        self.region_names: tuple[str, ...] = tuple(self.mapper.names)
        self._region_id = {name: i for i, name in enumerate(self.region_names)}
        self.expert_names: tuple[str, ...] = self.region_names if config.partition else ("all",)
        n_sonar = self.robot.n_sensors
        self.input_dim = n_sonar + config.goal_codes
        self.experts = nn.ModuleList(
            GrowingRBFExpert(
                dim=self.input_dim,
                width=config.width,
                novelty_radius=config.novelty_radius,
                capacity=config.capacity,
                max_neurons=config.max_neurons,
                name=name,
            )
            for name in self.expert_names
        )
        start, goal = self.world.start, self.world.goal
        self.start_distance = max(math.hypot(start.x - goal.x, start.y - goal.y), 1e-9)
        n_codes = config.goal_codes
        self._code_centres = [m / (n_codes - 1) for m in range(n_codes)]  # mu_m = m / 7
        self.register_buffer(
            "temperature", torch.tensor(float(config.temperature0), dtype=torch.float64)
        )
        self.register_buffer("best_total", torch.tensor(-math.inf, dtype=torch.float64))
        self.register_buffer("trials_done", torch.zeros((), dtype=torch.long))
        self.generator = torch.Generator().manual_seed(int(seed))
        # Sub-goal options (issue #4): where the reflex steers, chosen per region and trial.
        self.options = (
            OptionSteering.from_learner_config(config, self.world, seed) if config.options else None
        )
        # one reflex per avoidance desirability the option learner may choose (option_avoidance)
        self.avoid_reflexes = nn.ModuleList(
            FuzzyReflex(replace(self.reflex.config, d_a=d_a)) for d_a in config.option_avoidance
        )
        self.shield = (
            IRShield(ShieldConfig(margin=config.shield_margin), self.robot)
            if config.shield
            else None
        )
        self._noise = np.empty(0, dtype=np.float32)
        self._noise_at = 0
        self._held: Perception | None = None
        self.spec = Composite(
            action=Bounded(-_PI, _PI, shape=(1,), dtype=torch.float32),
            region=Unbounded(shape=(), dtype=torch.long),
            expert=Unbounded(shape=(), dtype=torch.long),
            winner=Unbounded(shape=(), dtype=torch.long),
            x=Unbounded(shape=(self.input_dim,), dtype=torch.float32),
            xi=Unbounded(shape=(), dtype=torch.float32),
            sigma=Unbounded(shape=(), dtype=torch.float32),
            grown=Categorical(n=2, shape=(), dtype=torch.bool),
            shielded=Categorical(n=2, shape=(), dtype=torch.bool),
        )

    # -- sizes ----------------------------------------------------------------------------
    def neurons(self) -> dict[str, int]:
        """Neurons per expert, by expert name."""
        return {e.name: len(e) for e in self.experts}

    def total_neurons(self) -> int:
        return sum(len(e) for e in self.experts)

    # -- perception -----------------------------------------------------------------------
    def encode(self, sonar: torch.Tensor, goal_distance: torch.Tensor | float) -> torch.Tensor:
        """x = (sonars, goal-distance codes) (Eq. 2); rho clipped to [0, 1].

        The 8 codes are computed in plain Python: ~15 us cheaper per step than 4 tensor ops."""
        rho = min(max(float(goal_distance) / self.start_distance, 0.0), 1.0)
        w = self.config.goal_code_width
        codes = torch.tensor([math.exp(-(((m - rho) / w) ** 2)) for m in self._code_centres])
        return torch.cat((sonar, codes))

    def region_of(self, odometry: tuple[float, float, float]) -> int:
        """Map region id of one pose: the map's scalar rules (``RegionMapper`` batches the same
        rules and is tested to agree; this path costs ~8 us per step against ~100 us)."""
        return self._region_id[self.world.regions.region_of(odometry[0], odometry[1])]

    def perceive(
        self, obs: Observation, reward: float | None = None, grow: bool = True
    ) -> Perception:
        """Gate, winner search and distance-driven growth (ALGORITHM.md steps 1-5).

        ``reward`` is the reinforcement received on arriving here (the new neuron's utility,
        paper 8.3); at a trial's first state it is computed from the observation instead.
        """
        odo = tuple(obs.odometry.tolist())
        region = self.region_of(odo)
        k = region if self.config.partition else 0
        x = self.encode(obs.sonar, obs.goal[0])
        if not self.config.learning:
            return Perception(region, k, -1, True, False, x, odo)
        expert = self.experts[k]
        i, dist = expert.nearest(x)
        novel = i < 0 or expert.is_novel(dist)
        grown = False
        if novel and grow:
            with torch.no_grad():
                i = expert.add(x, self.new_neuron_action(obs, k), self.initial_utility(obs, reward))
            grown = True
        return Perception(region, k, i, novel, grown, x, odo)

    def hold(self, perception: Perception) -> None:
        """Keep a perception of the next state for the next :meth:`forward` (set by the loss)."""
        self._held = perception

    def _take_held(self, obs: Observation) -> Perception | None:
        held, self._held = self._held, None
        if held is not None and held.odometry == tuple(obs.odometry.tolist()):
            return held
        return None

    # -- hooks for variants ---------------------------------------------------------------
    def reflex_target(self, obs: Observation, expert: int) -> float:
        """The signed angle the reflex's goal following steers toward (default: the goal).

        Override (or replace) to steer toward sub-goals, e.g. one per region. With
        ``learner.options`` it is the angle to the sub-goal the option learner chose."""
        if self.options is not None:
            odo = tuple(obs.odometry.tolist())
            return self.options.angle(self.region_of(odo), odo, exploration_type() in _GREEDY)
        return float(obs.goal[1])

    def reflex_action(self, obs: Observation, expert: int) -> float:
        """The fuzzy reflex's crisp angle for this observation.

        Computed in float64 (``FuzzyReflex.angle``: the same number as calling the module on
        ``sonar.double()``, with plain floats for one sample, ~5x cheaper). With
        ``learner.option_avoidance`` the reflex has the d_a the option learner chose here."""
        reflex = self.reflex
        if self.options is not None and self.options.avoid_learner is not None:
            odo = tuple(obs.odometry.tolist())
            greedy = exploration_type() in _GREEDY
            reflex = self.avoid_reflexes[self.options.avoidance(self.region_of(odo), greedy)]
        return reflex.angle(obs.sonar, self.reflex_target(obs, expert))

    def new_neuron_action(self, obs: Observation, expert: int) -> float:
        """Prototypical action of a new neuron: the reflex's (paper 8.3) or uniform random;
        0 with ``learner.residual`` (its action is a correction added to the reflex's)."""
        if self.config.residual and self.config.reflex:
            return 0.0
        if self.config.reflex:
            return self.reflex_action(obs, expert)
        return float(torch.rand((), generator=self.generator)) * 2 * _PI - _PI

    def state_reinforcement(self, obs: Observation) -> float:
        """r(state) = f1 + f2 (Eqs. 3-4) computed from an observation (used at a trial's start)."""
        robot = self.robot
        collision = (
            float(obs.bumper.max()) > 0.5 or float(obs.ir.max()) > robot.ir_collision_threshold
        )
        if collision:
            f1 = -3.0
        else:
            dmin = float(obs.sonar.min()) * robot.sonar_range
            f1 = -1.0 + dmin / robot.close_distance if dmin < robot.close_distance else 0.0
        return f1 - abs(float(obs.goal[1])) / _PI

    def initial_utility(self, obs: Observation, reward: float | None) -> float:
        """Utility of a new neuron (config ``utility_init``)."""
        rule = self.config.utility_init
        if rule == "zero":
            return 0.0
        r = self.state_reinforcement(obs) if reward is None else reward
        if rule == "discounted":
            return r / max(1.0 - self.config.gamma, 1e-6)
        return r

    # -- exploration ----------------------------------------------------------------------
    def _normal(self) -> float:
        if self._noise_at >= self._noise.shape[0]:
            self._noise = torch.randn(_NOISE_BLOCK, generator=self.generator).numpy()
            self._noise_at = 0
        z = self._noise[self._noise_at]
        self._noise_at += 1
        return float(z)

    def sigma(self, utility: float) -> float:
        """sigma = T / (1 + e^u) (Eq. 6)."""
        return float(self.temperature) / (1.0 + math.exp(min(utility, 60.0)))

    # -- TensorDictModule API ---------------------------------------------------------------
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        obs = Observation.from_td(td)
        greedy = exploration_type() in _GREEDY
        per = self._take_held(obs) or self.perceive(obs, grow=not greedy)
        xi = sigma = 0.0
        taken = None  # the neuron whose action is remembered, and the base it corrects
        if not self.config.learning:
            alpha = self.reflex_action(obs, per.expert)
        elif per.winner < 0 or (greedy and per.novel):
            alpha = self.new_neuron_action(obs, per.expert)
            if self.config.residual and self.config.reflex:
                alpha = self.reflex_action(obs, per.expert)
        else:
            rows = self.experts[per.expert].rows
            i = per.winner
            if greedy:
                xi = float(rows.means[i])
            else:
                sigma = self.sigma(float(rows.utilities[i]))
                xi = float(rows.means[i]) + sigma * self._normal()
            base = 0.0  # residual: the neuron's action corrects the reflex's current one
            if self.config.residual and self.config.reflex:
                base = self.reflex_action(obs, per.expert)
            alpha = min(max(base + float(rows.actions[i]) + xi, -_PI), _PI)
            if not greedy:
                taken = (rows, i, base)
        shielded = False
        if self.shield is not None:
            alpha, shielded = self.shield.filter(obs.ir, alpha)
        if taken is not None:
            rows, i, base = taken
            rows.taken[i] = alpha - base  # remembered for action replacement (step 8)
            rows.used[i] = True
        td.set("action", torch.tensor([alpha], dtype=torch.float32))
        td.set("region", torch.tensor(per.region))
        td.set("expert", torch.tensor(per.expert))
        td.set("winner", torch.tensor(per.winner))
        td.set("x", per.x)
        td.set("xi", torch.tensor(xi, dtype=torch.float32))
        td.set("sigma", torch.tensor(sigma, dtype=torch.float32))
        td.set("grown", torch.tensor(per.grown))
        td.set("shielded", torch.tensor(shielded))
        return td

    # -- trial boundaries -----------------------------------------------------------------
    def end_trial(self, record: dict) -> None:
        """Forget per-trial state (held perception, neurons used); called by the loss."""
        self._held = None
        for expert in self.experts:
            expert.clear_trial()
        if self.options is not None:  # update the option critics, decay epsilon
            record.update(self.options.end_trial())
        self.trials_done += 1
