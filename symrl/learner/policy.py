"""The mixture-of-experts controller of B robots (paper Fig. 4, sections 6-8): it acts, it does
not learn.

Per step, for every robot of the batch at once (``docs/ALGORITHM.md``):

0. the pose the robot believes: its odometry pose, or with map localisation the pose its sonar
   scan gives in the map (:meth:`MixtureOfExpertsPolicy.belief`); "pose" below is this one;
1. x = (n normalised sonars, goal-distance codes phi_m = exp(-((mu_m - rho) / w)^2)), rho the
   distance to the goal from the pose over the start's distance, clipped to [0, 1] (with the
   pose input: the pose itself);
2. the region gate (the map's symbolic rules on the pose) picks one expert (always the same one
   without partition);
3. with sub-goal options, the region's option gives the point the reflex steers at;
4. the nearest neuron of that expert wins; if none lies within the novelty radius the state is
   *novel* and the robot acts as the neuron the update will grow there would: the reflex's
   action (or a random one without reflex, 0 for a residual correction), utility r(state);
5. sigma = T / (1 + e^u), xi ~ N(mu, sigma^2), action = clip(base + p + xi, -pi, pi), base the
   reflex's current action for residual experts, else 0;
6. with the shield, an action whose move would graze a wall becomes the nearest safe angle.

It writes what it decided into the TensorDict (``out_keys``); the update
(:class:`symrl.learner.loss.TeseoLoss`) reads those keys and the transition, and writes the
parameters this module holds. With TorchRL's exploration type DETERMINISTIC / MODE / MEAN the
policy is greedy and draws no noise.

Each robot b has its own random streams (seeded ``seeds[b]``), so robot b of a batch acts as
the same seed alone.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs.utils import ExplorationType, exploration_type

from symrl.grad import no_grad
from symrl.knowledge.borders import border_subgoals
from symrl.knowledge.localize import MapLocalizer, PoseTracker
from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.regions import RegionMapper
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.shield import IRShield, ShieldConfig
from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import RunConfig
from symrl.learner.experts import ExpertBank
from symrl.learner.options import SubgoalOptions
from symrl.tensordicts import read, write
from symrl.world.geometry import Walls
from symrl.world.physics import goal_reading
from symrl.world.worldmap import WorldMap, load_map

__all__ = ["Perception", "MixtureOfExpertsPolicy", "OBS_KEYS", "is_greedy"]

OBS_KEYS = ("sonar", "ir", "odometry", "goal", "state_reward")
_GREEDY = (ExplorationType.DETERMINISTIC, ExplorationType.MODE, ExplorationType.MEAN)
_PI = math.pi
_PER_ROBOT = {
    "temperature", "best_total", "trials_done", "options.q", "options.n", "options.epsilon",
    "options.trials", "options.choice", "options.stage", "options.visit", "options.stalled",
}  # fmt: skip
"""State-dict entries with one row per robot (besides every ``experts.*`` buffer)."""
_BLOCK = 1024  # random draws per robot per refill: one call per robot instead of one per step


_GateAndInputs = tuple[torch.Tensor, torch.Tensor, torch.Tensor]


def is_greedy() -> bool:
    """True under a deterministic TorchRL exploration type (evaluation)."""
    return exploration_type() in _GREEDY


class Perception(NamedTuple):
    """What the gate and the winner search make of a batch of observations (read-only)."""

    region: torch.Tensor
    """(B,) map region ids of the odometry poses (order of the map's region names)."""
    expert: torch.Tensor
    """(B,) expert indices (= region with partition, else 0)."""
    x: torch.Tensor
    """(B, D) inputs."""
    winner: torch.Tensor
    """(B,) nearest neuron (-1: the expert is empty)."""
    novel: torch.Tensor
    """(B,) bool: no neuron within the novelty radius."""


class MixtureOfExpertsPolicy(TensorDictModuleBase):
    """Region-gated growing RBF experts acting through Gullapalli's Gaussian unit (Eq. 6).

    Reads ``sonar``, ``ir``, ``odometry``, ``goal``, ``state_reward`` of a batch [B] and writes
    ``action`` (B, 1) and the decision: ``region``, ``expert``, ``winner`` (-1 when novel),
    ``novel``, ``x``, ``proto`` (the action a new neuron here gets), ``xi`` (exploration draw),
    ``sigma``, ``taken`` (the action relative to its base, remembered for action replacement),
    ``shielded``, ``aim`` (B, 2) (the point the reflex steered at: the goal or the option's
    sub-goal), with options ``option`` and ``option_entry``, and ``pose`` (B, 3): the pose it
    believed (the odometry's, or the map localisation's).
    """

    in_keys = list(OBS_KEYS)
    out_keys = [
        "action", "region", "expert", "winner", "novel", "x", "proto", "xi", "sigma", "taken",
        "shielded", "aim", "option", "option_entry", "pose",
    ]  # fmt: skip

    temperature: torch.Tensor
    best_total: torch.Tensor
    trials_done: torch.Tensor

    def __init__(
        self,
        config: RunConfig,
        knowledge: Knowledge | WorldMap | None = None,
        seeds: list[int] | None = None,
        subgoals: SubgoalTable | None = None,
    ) -> None:
        """``knowledge``: what the robot is told (``symrl.knowledge.rungs``); a ``WorldMap`` (or
        None: ``config.env.map``) is cut down to the rung ``config.knowledge`` declares, so the
        agent never holds more. ``subgoals``: the map's sub-goal table if already built (it is
        derived from the map and ``config.options`` alone; building it takes tens of
        milliseconds)."""
        super().__init__()
        self.config = config
        if not isinstance(knowledge, Knowledge):
            world = knowledge if knowledge is not None else load_map(config.env.map)
            knowledge = Knowledge.told(world, config.knowledge)
        elif knowledge.rung != config.knowledge:
            raise ValueError(
                f"knowledge={config.knowledge} in the config, but the agent is handed "
                f"knowledge of rung {knowledge.rung!r}"
            )
        self.knowledge = knowledge
        self.seeds = list(seeds) if seeds is not None else [config.run.seed]
        batch = len(self.seeds)
        robot = config.env.robot
        xc = config.experts
        lc = config.localize
        self.localizer = (
            PoseTracker(MapLocalizer(Walls(knowledge.geometry("localize").segments), robot,
                                     lc.iterations, lc.prior_xy, lc.prior_heading,
                                     max_move=lc.max_move),
                        batch)
            if lc.enabled
            else None
        )  # fmt: skip
        self._beliefs: dict[bytes, tuple[torch.Tensor, torch.Tensor]] = {}
        self.mapper = RegionMapper(knowledge.regions)
        self.region_names: tuple[str, ...] = tuple(self.mapper.names)
        self.expert_names = self.region_names if config.gate.partition else ("all",)
        self.reflex = FuzzyReflex(config.reflex)
        self.input_dim = 4 if xc.input == "pose" else robot.n_sensors + xc.goal_codes
        self.experts = ExpertBank(
            batch, len(self.expert_names), self.input_dim, xc.capacity, xc.max_neurons,
            names=self.expert_names,
        )  # fmt: skip
        self.options = None
        if config.options.enabled and config.options.source != "map":
            # the borders of the region rules, or the passages the robot is told of
            told = knowledge.passages if config.options.source == "passages" else None
            table = subgoals or border_subgoals(knowledge.regions, knowledge.goal, told)
            self.options = SubgoalOptions(knowledge, batch, config.options, self.seeds, table,
                                          step=robot.step)  # fmt: skip
        elif config.options.enabled:
            self.options = SubgoalOptions(knowledge.geometry("options"), batch, config.options,
                                          self.seeds, subgoals, step=robot.step)  # fmt: skip
        self.shield = (
            IRShield(ShieldConfig(margin=config.shield.margin), robot)
            if config.shield.enabled
            else None
        )
        start, goal = knowledge.start, knowledge.goal
        self.start_distance = max(math.hypot(start.x - goal.x, start.y - goal.y), 1e-9)
        n = xc.goal_codes
        self.register_buffer("code_centres", torch.arange(n, dtype=torch.float32) / (n - 1))
        t0 = config.update.temperature0
        self.register_buffer("temperature", torch.full((batch,), t0, dtype=torch.float64))
        self.register_buffer("best_total", torch.full((batch,), -math.inf, dtype=torch.float64))
        self.register_buffer("trials_done", torch.zeros(batch, dtype=torch.long))
        self.generators = [torch.Generator().manual_seed(int(s)) for s in self.seeds]
        self._normals = torch.empty(batch, 0)
        self._uniforms = torch.empty(batch, 0)
        self._drawn = 0
        # constant outputs for the parts a recipe leaves out (never written in place)
        self._zeros = torch.zeros(batch, dtype=torch.float64)
        self._zeros_np = self._zeros.numpy()
        self._no_option = torch.full((batch,), -1, dtype=torch.long)
        self._no_entry = torch.zeros(batch, dtype=torch.bool)
        self._goal_aim = torch.tensor([[goal.x, goal.y]], dtype=torch.float64).repeat(batch, 1)
        # the observation of the last perception and its (region, expert, x)
        self._last_seen: tuple[tuple, _GateAndInputs] | None = None

    @property
    def subgoals(self) -> SubgoalTable | None:
        """The sub-goal table in use (None without options)."""
        return self.options.table if self.options is not None else None

    @property
    def batch(self) -> int:
        return len(self.seeds)

    # -- perception (read-only; the update calls it on the next state) --------------------
    def belief(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The pose the robot steers by and the goal's (distance, angle) from it: the odometry's
        as observed, or with map localisation the pose its sonar scan gives in the map
        (``symrl.knowledge.localize``). The policy and the update ask for the same two
        observations in turn, so the last two answers are kept, by the observations' bits."""
        if self.localizer is None:
            return odometry, goal
        key = odometry.numpy().tobytes() + sonar.numpy().tobytes()
        known = self._beliefs.get(key)
        if known is not None:
            return known
        pose = self.localizer(odometry.numpy(), sonar.numpy())
        g = self.knowledge.goal
        seen = goal_reading(g.x, g.y, pose[:, 0], pose[:, 1], pose[:, 2])
        out = torch.from_numpy(pose.astype(np.float32)), torch.from_numpy(seen)
        if len(self._beliefs) >= 2:
            del self._beliefs[next(iter(self._beliefs))]
        self._beliefs[key] = out
        return out

    def encode(self, sonar: torch.Tensor, goal_distance: torch.Tensor) -> torch.Tensor:
        """x = (sonars, goal-distance codes) (Eq. 2); rho clipped to [0, 1]."""
        rho = (goal_distance.to(torch.float32) / self.start_distance).clamp(0.0, 1.0)
        width = self.config.experts.goal_code_width
        codes = torch.exp(-(((self.code_centres - rho[:, None]) / width) ** 2))
        return torch.cat((sonar, codes), dim=-1)

    def encode_pose(self, odometry: torch.Tensor) -> torch.Tensor:
        """x = (x, y, h cos theta, h sin theta) of the odometry pose, h = ``heading_scale``."""
        h = self.config.experts.heading_scale
        # numpy on the tensor's memory (four columns of a handful of rows); cos and sin stay
        # torch's, whose last bit differs from numpy's
        pose = odometry.numpy().astype(np.float32, copy=False)
        theta = torch.from_numpy(pose[:, 2])
        x = np.empty((len(pose), 4), dtype=np.float32)  # the four columns written in place
        x[:, :2] = pose[:, :2]
        np.multiply(h, theta.cos().numpy(), out=x[:, 2])
        np.multiply(h, theta.sin().numpy(), out=x[:, 3])
        return torch.from_numpy(x)

    def perceive(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> Perception:
        """Gate and winner search for a batch of observations; changes nothing that is learned
        (the result's tensors are read-only: the gate and the inputs may be those of the
        previous call; with map localisation the tracker keeps each robot's last correction,
        where its next estimate starts)."""
        region, expert, x, winner, novel = self.perceive_arrays(sonar, odometry, goal)
        return Perception(region, expert, x, torch.from_numpy(winner), torch.from_numpy(novel))

    def perceive_arrays(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray, np.ndarray]:
        """:meth:`perceive` with the winner and the novelty as numpy arrays (the control loop
        reads them as numpy: no tensors in between)."""
        return self.perceive_believed(sonar, *self.belief(sonar, odometry, goal))

    def perceive_believed(
        self, sonar: torch.Tensor, pose: torch.Tensor, goal: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray, np.ndarray]:
        """:meth:`perceive_arrays` at the believed ``pose`` and ``goal`` (:meth:`belief`'s
        answer, for a caller that has it already)."""
        region, expert, x = self._gate_and_inputs(sonar, pose, goal)
        if not self.config.experts.learning:
            return region, expert, x, np.full(len(region), -1), np.ones(len(region), dtype=bool)
        winner, distance = self.experts.nearest_np(expert.numpy(), x.numpy())
        novel = distance > self.config.experts.novelty_radius  # inf for an empty expert
        return region, expert, x, winner, novel

    def _gate_and_inputs(
        self, sonar: torch.Tensor, pose: torch.Tensor, goal: torch.Tensor
    ) -> _GateAndInputs:
        """Region, expert and input x of a batch of observations. They depend on the
        observation alone, and the loop asks twice for most observations (the update perceives
        the state reached, then the policy acts on it), so the last result is kept with a copy
        of the observation it came from and reused when the same bits come again (about a
        fifth of the cost of the two calls: ``benchmarks/bench_train.py``)."""
        pose_input = self.config.experts.input == "pose"
        seen = (pose,) if pose_input else (sonar, pose, goal)
        # the observation's bits (bitwise: -0.0 is not 0.0, NaN is NaN), read through numpy:
        # a byte string compares for a fraction of a torch.equal's cost
        key = tuple((t.dtype, t.shape, t.numpy().tobytes()) for t in seen)
        last = self._last_seen
        if last is not None and last[0] == key:
            return last[1]
        region = torch.from_numpy(self.mapper.ids_np(pose.numpy()[:, :2].astype(np.float64)))
        expert = region if self.config.gate.partition else torch.zeros_like(region)
        x = self.encode_pose(pose) if pose_input else self.encode(sonar, goal[:, 0])
        self._last_seen = (key, (region, expert, x))
        return region, expert, x

    # -- random streams -------------------------------------------------------------------
    def _draws(self) -> tuple[np.ndarray, np.ndarray]:
        """One standard normal and one uniform per robot from its own generator (numpy views
        of the pre-drawn blocks)."""
        if self._drawn >= self._normals.shape[1]:
            self._normals = torch.stack(
                [torch.randn(_BLOCK, generator=g, dtype=torch.float64) for g in self.generators]
            )
            self._uniforms = torch.stack(
                [torch.rand(_BLOCK, generator=g, dtype=torch.float64) for g in self.generators]
            )
            self._drawn = 0
        i = self._drawn
        self._drawn += 1
        return self._normals.numpy()[:, i], self._uniforms.numpy()[:, i]

    # -- acting ---------------------------------------------------------------------------
    @no_grad
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        xc = self.config.experts
        greedy = is_greedy()
        sonar = read(td, "sonar")
        pose, goal = self.belief(sonar, read(td, "odometry"), read(td, "goal"))
        region, expert, x, winner, novel = self.perceive_believed(sonar, pose, goal)
        zero = self._zeros
        option, entered, aim = self._no_option, self._no_entry, self._goal_aim
        if self.options is not None:
            target, option, entered, aim = self.options.steer(region, pose, greedy)
        else:
            target = goal[:, 1].to(torch.float64)
        if xc.reflex or not xc.learning:
            # float32 widened exactly, in numpy (a torch cast is a dispatch more)
            reflex_action = self.reflex(torch.from_numpy(sonar.numpy().astype(np.float64)), target)
            if self.options is not None and self.options.start_turn.any():
                # a trial's first action with the aim behind: straight at it, in one action
                turn = self.options.start_turn
                reflex_action = torch.from_numpy(
                    np.where(turn, target.numpy(), reflex_action.numpy())
                )
        else:
            reflex_action = zero
        xi = sigma = zero
        if not xc.learning:
            base = proto = zero
            alpha = reflex_action
        else:
            # numpy on the tensors' memory (a handful of rows: a fraction of the torch
            # dispatches); exp stays torch's, the rest is exact arithmetic in the same order
            z, uniform = (self._zeros_np, self._zeros_np) if greedy else self._draws()
            if xc.residual:
                base, proto = reflex_action, zero
            elif xc.reflex:
                base, proto = zero, reflex_action
            else:
                base, proto = zero, torch.from_numpy(uniform * (2 * _PI) - _PI)
            bank = self.experts
            index = bank.flat_index_np(expert.numpy(), np.maximum(winner, 0))
            known = ~novel
            flat = bank.flat
            p = np.where(known, flat.actions[index], proto.numpy())
            mu = np.where(known, flat.means[index], 0.0)
            if greedy:
                noisy = mu
            else:
                # a novel state's neuron is born with u = r(state): the reward of arriving here
                u_new = read(td, "state_reward").numpy().reshape(-1).astype(np.float64)
                u = np.where(known, flat.utilities[index], u_new)
                e = torch.from_numpy(np.minimum(u, 60.0)).exp().numpy()
                spread = self.temperature.numpy() / (1.0 + e)
                noisy = mu + spread * z
                sigma = torch.from_numpy(spread)
            xi = torch.from_numpy(noisy)
            # clipped to [-pi, pi] by min/max (np.clip's dispatch costs about twice as much)
            alpha = torch.from_numpy(np.minimum(np.maximum(base.numpy() + p + noisy, -_PI), _PI))
        shielded = self._no_entry
        if self.shield is not None:
            alpha, shielded = self.shield(read(td, "ir"), alpha)
        action = alpha.numpy()
        write(
            td,
            {
                "action": torch.from_numpy(action.astype(np.float32).reshape(-1, 1)),
                "region": region,
                "expert": expert,
                "winner": torch.from_numpy(np.where(novel, -1, winner)),
                "novel": torch.from_numpy(novel),
                "x": x,
                "proto": proto,
                "xi": xi,
                "sigma": sigma,
                "taken": torch.from_numpy(action - base.numpy()),
                "shielded": shielded,
                "option": option,
                "option_entry": entered,
                "aim": aim,
                "pose": pose,
            },
        )
        return td

    @no_grad
    def begin_trial(self, rows: torch.Tensor) -> None:
        """Forget the per-trial decisions of robots ``rows`` (they start a new trial)."""
        if self.options is not None:
            self.options.begin_trial(rows)
        if self.localizer is not None:
            self.localizer.begin_trial(rows.numpy())
            self._beliefs.clear()

    # -- per-robot state ------------------------------------------------------------------
    def robot_state(self, b: int) -> dict[str, torch.Tensor]:
        """Robot ``b``'s controller: a cloned state dict that loads into a policy of one robot
        (``MixtureOfExpertsPolicy(config, policy.knowledge, [seed])``)."""
        out = {}
        for key, value in self.state_dict().items():
            per_robot = key.startswith("experts.") or key in _PER_ROBOT
            out[key] = (value[b : b + 1] if per_robot else value).clone()
        return out

    @classmethod
    def from_robot_states(
        cls,
        config: RunConfig,
        knowledge: Knowledge | WorldMap,
        states: list[dict[str, torch.Tensor]],
        seeds: list[int] | None = None,
        subgoals: SubgoalTable | None = None,
    ) -> MixtureOfExpertsPolicy:
        """One policy whose robot b is the controller ``states[b]`` (from :meth:`robot_state`
        or a one-robot policy's state dict): evaluate several controllers side by side."""
        seeds = list(seeds) if seeds is not None else [0] * len(states)
        policy = cls(config, knowledge, seeds, subgoals)
        merged = {}
        for key, value in states[0].items():
            if key.startswith("experts.") or key in _PER_ROBOT:
                parts = [s[key] for s in states]
                if value.dim() >= 3:  # (1, E, N, ...): pad the capacity to the largest
                    n = max(p.shape[2] for p in parts)
                    parts = [
                        torch.cat((p, p.new_zeros((*p.shape[:2], n - p.shape[2], *p.shape[3:]))), 2)
                        for p in parts
                    ]
                merged[key] = torch.cat(parts, dim=0)
            else:
                merged[key] = value
        policy.load_state_dict(merged)
        return policy

    # -- sizes ----------------------------------------------------------------------------
    def neurons(self) -> torch.Tensor:
        """Neurons per robot and expert (B, E)."""
        return self.experts.neurons()
