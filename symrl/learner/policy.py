"""The mixture-of-experts controller of B robots (paper Fig. 4, sections 6-8): it acts, it does
not learn.

It reads the TensorDict's ``sonar``, ``ir``, ``state_reward`` and the keys its perception
transform wrote, ``pose``, ``belief_goal``, ``region``, ``expert``, ``x`` and ``is_init``, and
nothing else: it does not perceive. A TensorDict without them (an env without the transform) is
a :class:`PerceptionMissing` error. The policy is handed what it needs by the assembly
(:mod:`symrl.assembly`): what the robot is told (its ``Knowledge``), the perception transform,
the ``experts`` config section, the reflex, the initial temperature and, where the recipe has
them, the sub-goal options and the IR shield; it neither cuts the world to its rung nor builds
its perception.

Per step, for every robot of the batch at once (``docs/explanation/algorithm.md``); steps 0-2 are
the robot's perception (:class:`symrl.learner.perception.Perception`, the TorchRL env transform
the policy is handed: the env writes them once per observation):

0. the pose the robot believes: its odometry pose, or with map localisation the pose its sonar
   scan gives in the map; "pose" below is this one;
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
(:class:`symrl.learner.update.TeseoUpdate`) reads those keys and the transition. What is learned
lives in modules the policy holds and hands to the update: the experts (whose parameters the
update steps, as an optimiser steps a network's), ``progress``
(:class:`~symrl.learner.progress.TrialProgress`: the temperature, the best total, the trials
done) and the options' ``critic``; each is written only through its own methods. With
TorchRL's exploration type DETERMINISTIC / MODE / MEAN the policy is greedy and draws no noise.

Each robot b has its own random streams (seeded ``seeds[b]``), so robot b of a batch acts as
the same seed alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.envs.utils import ExplorationType, exploration_type

from symrl.grad import no_grad
from symrl.knowledge.reflex import FuzzyReflex
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.shield import IRShield
from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import ExpertsConfig
from symrl.learner.experts import ExpertBank
from symrl.learner.options import SubgoalOptions
from symrl.learner.perception import INIT_KEY, PERCEPTION_KEYS, Perception
from symrl.learner.progress import TrialProgress
from symrl.tensordicts import read, write

__all__ = [
    "PerceptionResult",
    "MixtureOfExpertsPolicy",
    "OBS_KEYS",
    "PerceptionMissing",
    "is_greedy",
]

OBS_KEYS = ("sonar", "ir", "state_reward")
"""The observation keys the policy reads beside its perception transform's."""
_GREEDY = (ExplorationType.DETERMINISTIC, ExplorationType.MODE, ExplorationType.MEAN)
_PI = math.pi
_PER_ROBOT = {"options.choice", "options.stage", "options.visit"}
_PER_ROBOT_MODULES = (
    "experts.",
    "progress.",
    "options.critic.",
    "options.crossings.",
    "options.remembered_way.",
    "options.goal_scans.",
)
"""State-dict entries with one row per robot: those named, and every buffer of those modules."""
_BLOCK = 1024  # random draws per robot per refill: one call per robot instead of one per step


def is_greedy() -> bool:
    """True under a deterministic TorchRL exploration type (evaluation)."""
    return exploration_type() in _GREEDY


class PerceptionResult(NamedTuple):
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


class PerceptionMissing(KeyError):
    """The policy was driven on a TensorDict its perception transform did not write."""

    def __str__(self) -> str:
        return (
            "policy: no 'pose' in the TensorDict (the perception transform's key): drive it on "
            "an env with its perception transform appended (symrl.assembly.assemble, or "
            "env.append_transform(policy.perception_transform()))"
        )


_PERCEPTION = "perception."


def _without_perception(module: Any, state: dict[str, Any], prefix: str, metadata: Any) -> None:
    """Drop the perception's entries from a policy's state dict (they are its ``mapper.``)."""
    for key in [k for k in state if k.startswith(prefix + _PERCEPTION)]:
        del state[key]


def _perception_not_missing(module: Any, incompatible: Any) -> None:
    """A state dict of a policy holds no perception entries: none is missing."""
    incompatible.missing_keys[:] = [
        k for k in incompatible.missing_keys if f".{_PERCEPTION}" not in f".{k}"
    ]


class MixtureOfExpertsPolicy(TensorDictModuleBase):
    """Region-gated growing RBF experts acting through Gullapalli's Gaussian unit (Eq. 6).

    Reads ``sonar``, ``ir``, ``state_reward`` of a batch [B] and what its perception
    transform (:meth:`perception_transform`) made of them: ``pose`` (the pose it believes),
    ``belief_goal``, ``region``, ``expert``, ``x`` (without them: :class:`PerceptionMissing`)
    and, where the transform marks a trial's first state, ``is_init``: it forgets those robots'
    per-trial decisions
    (:meth:`begin_trial`) before acting. Writes ``action`` (B, 1) and the
    decision: ``winner`` (-1 when novel), ``novel``, ``proto`` (the action a new neuron here
    gets), ``xi`` (exploration draw), ``sigma``, ``taken`` (the action relative to its base,
    remembered for action replacement), ``shielded``, ``aim`` (B, 2) (the point the reflex
    steered at: the goal or the option's sub-goal), with options ``option`` and
    ``option_entry``, ``option_border`` (B,) the border the option leads across (-1: the goal),
    and ``wall_follow`` (B,) bool: the robot follows a wall out of a trap.
    """

    in_keys = [*OBS_KEYS, *PERCEPTION_KEYS, INIT_KEY]
    out_keys = [
        "action",
        "winner",
        "novel",
        "proto",
        "xi",
        "sigma",
        "taken",
        "shielded",
        "aim",
        "option",
        "option_entry",
        "option_border",
        "wall_follow",
    ]

    def __init__(
        self,
        knowledge: Knowledge,
        perception: Perception,
        seeds: Sequence[int],
        experts: ExpertsConfig,
        reflex: FuzzyReflex,
        temperature0: float,
        options: SubgoalOptions | None = None,
        shield: IRShield | None = None,
    ) -> None:
        """B = ``len(seeds)`` robots told ``knowledge``, perceiving through ``perception``
        (the transform of their env, built for the same knowledge and batch), with the config
        section ``experts``, the reflex, the initial temperature ``update.temperature0`` and,
        where the recipe has them, the sub-goal options and the IR shield. Build it with
        :func:`symrl.assembly.build_policy`, which cuts the world to the recipe's rung."""
        super().__init__()
        if perception.batch != len(seeds):
            raise ValueError(
                f"seeds: {len(seeds)} robots, but the perception is built for {perception.batch}"
            )
        self.knowledge = knowledge
        self.experts_config = experts
        self.seeds = [int(s) for s in seeds]
        batch = len(self.seeds)
        # what the robot makes of an observation: the TorchRL env transform it is handed. A
        # submodule (``.to()`` and the module tree reach it) whose entries stay out of the
        # state dict: its region rules and goal codes are saved as ``mapper.`` and
        # ``code_centres``, the keys of every saved controller
        self.perception = perception
        self.register_state_dict_post_hook(_without_perception)
        self.register_load_state_dict_post_hook(_perception_not_missing)
        self.mapper = perception.mapper
        self.region_names: tuple[str, ...] = tuple(self.mapper.names)
        self.expert_names = self.region_names if perception.partition else ("all",)
        self.reflex = reflex
        self.input_dim = perception.input_dim
        self.experts = ExpertBank(
            batch,
            len(self.expert_names),
            self.input_dim,
            experts.capacity,
            experts.max_neurons,
            names=self.expert_names,
        )
        self.options = options
        self.shield = shield
        goal = knowledge.goal
        self.register_buffer("code_centres", perception.code_centres)
        self.progress = TrialProgress(batch, temperature0)
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

    @property
    def subgoals(self) -> SubgoalTable | None:
        """The sub-goal table in use (None without options)."""
        return self.options.table if self.options is not None else None

    @property
    def batch(self) -> int:
        return len(self.seeds)

    # -- perception ---------------------------------------------------------------------
    def perception_transform(self) -> Perception:
        """The robot's perception as a TorchRL env transform (``env.append_transform``), the
        one the policy was handed: it writes ``pose``, ``belief_goal``, ``region``, ``expert``
        and ``x`` on reset and step, which the policy and the update read. One env at a
        time."""
        return self.perception

    def perceive(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> PerceptionResult:
        """Gate and winner search for a batch of observations; changes nothing that is learned
        (with map localisation the tracker keeps each robot's last correction, where its next
        estimate starts)."""
        seen = self.perception.perceive(sonar, odometry, goal)
        winner, novel = self._winners(seen["expert"], seen["x"])
        return PerceptionResult(
            seen["region"],
            seen["expert"],
            seen["x"],
            torch.from_numpy(winner),
            torch.from_numpy(novel),
        )

    def _winners(self, expert: torch.Tensor, x: torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
        """The nearest neuron of each robot's expert to its input and whether none lies within
        the novelty radius (numpy: the control loop reads them so)."""
        if not self.experts_config.learning:
            return np.full(len(expert), -1), np.ones(len(expert), dtype=bool)
        winner, distance = self.experts.nearest_np(expert.numpy(), x.numpy())
        return winner, distance > self.experts_config.novelty_radius  # inf for an empty expert

    # -- random streams -------------------------------------------------------------------
    def random_state(self) -> dict[str, Any]:
        """Every random stream of the policy (a run snapshot): each robot's exploration and
        option generators and the pre-drawn noise blocks not used yet (tensors and plain
        Python values)."""
        options = self.options
        return {
            "generators": [g.get_state() for g in self.generators],
            "option_generators": [g.get_state() for g in options.generators]
            if options is not None
            else [],
            "normals": self._normals.clone(),
            "uniforms": self._uniforms.clone(),
            "drawn": int(self._drawn),
        }

    def load_random_state(self, state: dict[str, Any]) -> None:
        """Go on drawing from :meth:`random_state` (a policy of the same config and seeds)."""
        for g, saved in zip(self.generators, state["generators"], strict=True):
            g.set_state(saved)
        if self.options is not None:
            for g, saved in zip(self.options.generators, state["option_generators"], strict=True):
                g.set_state(saved)
        self._normals = state["normals"].clone()
        self._uniforms = state["uniforms"].clone()
        self._drawn = int(state["drawn"])

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
        xc = self.experts_config
        greedy = is_greedy()
        sonar = read(td, "sonar")
        init = read(td, INIT_KEY, None)  # a trial's first state: forget the last trial's
        starting = None if init is None else init.numpy().reshape(-1)  # decisions there
        if starting is not None and starting.any():
            self.begin_trial(torch.from_numpy(np.flatnonzero(starting)))
        try:
            pose = read(td, "pose")
        except KeyError:
            raise PerceptionMissing() from None
        goal, region = read(td, "belief_goal"), read(td, "region")
        expert, x = read(td, "expert"), read(td, "x")
        winner, novel = self._winners(expert, x)
        zero = self._zeros
        option, entered, aim = self._no_option, self._no_entry, self._goal_aim
        border = self._no_option
        start_turn = None
        if self.options is not None:
            target, option, entered, aim, start_turn = self.options.steer(
                region, pose, greedy, sonar
            )
            border = self.options.aimed_border(region, option)
        else:
            target = goal[:, 1].to(torch.float64)
        if xc.reflex or not xc.learning:
            reflex_action = self._reflex_action(sonar, target, start_turn)
        else:
            reflex_action = zero
        if not xc.learning:
            base = proto = xi = sigma = zero
            alpha = reflex_action
        else:
            base, proto, xi, sigma, alpha = self._explore(
                td, expert, winner, novel, reflex_action, greedy
            )
        shielded = self._no_entry
        if self.shield is not None:
            alpha, shielded = self.shield(read(td, "ir"), alpha)
        action = alpha.numpy()
        write(
            td,
            {
                "action": torch.from_numpy(action.astype(np.float32).reshape(-1, 1)),
                "winner": torch.from_numpy(np.where(novel, -1, winner)),
                "novel": torch.from_numpy(novel),
                "proto": proto,
                "xi": xi,
                "sigma": sigma,
                "taken": torch.from_numpy(action - base.numpy()),
                "shielded": shielded,
                "option": option,
                "option_entry": entered,
                "option_border": border,
                "wall_follow": self._following(),
                "aim": aim,
            },
        )
        return td

    def _explore(
        self,
        td: TensorDictBase,
        expert: torch.Tensor,
        winner: np.ndarray,
        novel: np.ndarray,
        reflex_action: torch.Tensor,
        greedy: bool,
    ) -> tuple[torch.Tensor, ...]:
        """The learned action (Gullapalli's Gaussian unit, Eq. 6): ``base``, ``proto``, ``xi``,
        ``sigma`` and the action clipped to [-pi, pi]."""
        xc = self.experts_config
        zero = sigma = self._zeros
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
            spread = self.progress.arrays["temperature"] / (1.0 + e)
            noisy = mu + spread * z
            sigma = torch.from_numpy(spread)
        # clipped to [-pi, pi] by min/max (np.clip's dispatch costs about twice as much)
        alpha = torch.from_numpy(np.minimum(np.maximum(base.numpy() + p + noisy, -_PI), _PI))
        return base, proto, torch.from_numpy(noisy), sigma, alpha

    def _reflex_action(
        self, sonar: torch.Tensor, target: torch.Tensor, start_turn: np.ndarray | None
    ) -> torch.Tensor:
        """The reflex's action at the sonars steering at ``target``; at a trial's first action
        with the aim behind (``start_turn``), straight at it in one action."""
        # float32 widened exactly, in numpy (a torch cast is a dispatch more)
        action = self.reflex(torch.from_numpy(sonar.numpy().astype(np.float64)), target)
        if start_turn is not None and start_turn.any():
            action = torch.from_numpy(np.where(start_turn, target.numpy(), action.numpy()))
        return action

    def _following(self) -> torch.Tensor:
        """(B,) bool: which robots follow a wall out of a trap at this step."""
        follow = self.options.wall_follow if self.options is not None else None
        if follow is None:
            return self._no_entry
        return torch.from_numpy(follow.following.copy())

    @no_grad
    def begin_trial(self, rows: torch.Tensor) -> None:
        """Forget the per-trial decisions of robots ``rows`` (they start a new trial); called
        by :meth:`forward` where ``is_init`` marks a trial's first state."""
        if self.options is not None:
            self.options.begin_trial(rows)

    # -- per-robot state ------------------------------------------------------------------
    def robot_state(self, b: int) -> dict[str, torch.Tensor]:
        """Robot ``b``'s controller: a cloned state dict that loads into a policy of one robot
        (``symrl.assembly.build_policy(config, policy.knowledge, [seed])``)."""
        out = {}
        for key, value in self.state_dict().items():
            per_robot = key.startswith(_PER_ROBOT_MODULES) or key in _PER_ROBOT
            out[key] = (value[b : b + 1] if per_robot else value).clone()
        return out

    def load_robot_states(self, states: Sequence[dict[str, torch.Tensor]]) -> None:
        """Make robot b the controller ``states[b]`` (from :meth:`robot_state` or a one-robot
        policy's state dict; one state per robot): evaluate several controllers side by
        side."""
        if len(states) != self.batch:
            raise ValueError(f"states: {len(states)} controllers for a batch of {self.batch}")
        merged = {}
        for key, value in states[0].items():
            if key.startswith(_PER_ROBOT_MODULES) or key in _PER_ROBOT:
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
        self.load_state_dict(merged)

    # -- sizes ----------------------------------------------------------------------------
    def neurons(self) -> torch.Tensor:
        """Neurons per robot and expert (B, E)."""
        return self.experts.neurons()
