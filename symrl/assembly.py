"""Assembling a run: the one place that builds the world, the agent and its update.

:func:`assemble` builds, for B robots of a recipe, the TorchRL env of the world (one robot per
seed, the world's step budget applied to the config), cuts the world down to what the recipe's
rung tells the robot (``Knowledge.told(world, config.knowledge)``, once), builds the robot's
perception transform from that knowledge and appends it to the env, then the policy (handed
the knowledge and the transform), the collector and the update. Each part gets the config
sections it uses and nothing more:

    perception   env.robot, experts, localize, gate.partition, scan_odometry
    policy       experts; the reflex (reflex), the options (options, option_critic, crossings,
                 env.robot, env.max_actions), the shield (shield, env.robot), update.temperature0
    update       update, trial_gradient, env.robot, env.max_actions

:func:`assemble_greedy` builds the same for greedy trials of saved controllers (the evaluation
and the studies' other starts): a policy whose robots are the controllers, told what they
learned in, on an env of the world they drive in, without collector or update.
:func:`build_policy` and :func:`build_update` are the two steps on their own (a checkpoint's
controller, tests).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from symrl.learner.config import RunConfig

if TYPE_CHECKING:
    from symrl.collector import StepCollector
    from symrl.knowledge.rungs import Knowledge
    from symrl.knowledge.subgoals import SubgoalTable
    from symrl.learner.perception import Perception
    from symrl.learner.policy import MixtureOfExpertsPolicy
    from symrl.learner.update import TeseoUpdate
    from symrl.world.worldmap import WorldMap

__all__ = [
    "Assembly",
    "assemble",
    "assemble_greedy",
    "build_policy",
    "build_update",
    "make_env",
    "told",
    "with_budget",
]


@dataclass
class Assembly:
    """The parts of a training run, built by :func:`assemble`."""

    config: RunConfig
    """The run's config, its ``env.max_actions`` the world's step budget."""
    env: Any
    """The batched env of the world, the perception transform appended."""
    policy: MixtureOfExpertsPolicy
    update: TeseoUpdate
    collector: StepCollector

    @property
    def perception(self) -> Perception:
        """The perception transform appended to :attr:`env` (the policy's)."""
        return self.policy.perception_transform()


def make_env(config: RunConfig, seeds: Sequence[int], world: Any = None, starts: Any = None):
    """The world of ``config`` as a TorchRL env with one robot per seed (``world``: a loaded
    map, a map name or None for ``env.map``; ``starts``: (B, 3) start poses, else the map's)."""
    from symrl.world.batched_env import BatchedWorldEnv
    from symrl.world.budget import step_budget
    from symrl.world.worldmap import WorldMap, load_map

    ec = config.env
    world = world if isinstance(world, WorldMap) else load_map(ec.map if world is None else world)
    env = BatchedWorldEnv(
        world,
        size=len(seeds),
        robot=ec.robot,
        noise=ec.noise,
        max_actions=step_budget(world, ec.max_actions, ec.robot.step),
        seeds=list(seeds),
    )
    if starts is not None:
        env.set_starts(starts)
    return env


def with_budget(config: RunConfig, env: Any) -> RunConfig:
    """``config`` with ``env.max_actions`` the step budget ``env`` gives its robots (a big
    world's is larger, :func:`symrl.world.budget.step_budget`); the same config otherwise."""
    if env.physics.max_actions == config.env.max_actions:
        return config
    budget = {"max_actions": env.physics.max_actions}
    return config.model_copy(update={"env": config.env.model_copy(update=budget)})


def told(config: RunConfig, knowledge: Knowledge | WorldMap | None = None) -> Knowledge:
    """What a robot of ``config`` is told: a world (None: ``env.map``) cut down to the rung
    ``config.knowledge``; given knowledge must be of that rung."""
    from symrl.knowledge.rungs import Knowledge
    from symrl.world.worldmap import load_map

    if isinstance(knowledge, Knowledge):
        if knowledge.rung != config.knowledge:
            raise ValueError(
                f"knowledge={config.knowledge} in the config, but the agent is handed "
                f"knowledge of rung {knowledge.rung!r}"
            )
        return knowledge
    world = knowledge if knowledge is not None else load_map(config.env.map)
    return Knowledge.told(world, config.knowledge)


def build_policy(
    config: RunConfig,
    knowledge: Knowledge | WorldMap | None = None,
    seeds: Sequence[int] | None = None,
    subgoals: SubgoalTable | None = None,
    states: Sequence[dict[str, Any]] | None = None,
) -> MixtureOfExpertsPolicy:
    """The policy of B = ``len(seeds)`` robots (default ``[config.run.seed]``) told
    ``knowledge`` (a world or None: cut to ``config.knowledge``, :func:`told`), with its
    perception transform. ``subgoals``: the map's sub-goal table if already built (it is
    derived from the map and ``config.options`` alone; building it takes tens of
    milliseconds). ``states``: robot b's controller ``states[b]`` loaded
    (``policy.robot_state`` or a one-robot policy's state dict)."""
    from symrl.knowledge.reflex import FuzzyReflex
    from symrl.knowledge.shield import IRShield, ShieldConfig
    from symrl.learner.options import SubgoalOptions
    from symrl.learner.perception import Perception
    from symrl.learner.policy import MixtureOfExpertsPolicy

    knowledge = told(config, knowledge)
    seeds = [int(s) for s in seeds] if seeds is not None else [config.run.seed]
    batch, robot = len(seeds), config.env.robot
    perception = Perception(
        knowledge,
        batch,
        robot,
        config.experts,
        config.localize,
        config.gate.partition,
        config.scan_odometry,
    )
    reflex = FuzzyReflex(config.reflex)  # built before the options: the module order
    options = None
    if config.options.enabled:
        options = SubgoalOptions(
            knowledge,
            batch,
            config.options,
            seeds,
            subgoals,
            config.option_critic,
            config.crossings,
            robot,
            config.env.max_actions,
        )
    shield = None
    if config.shield.enabled:
        shield = IRShield(ShieldConfig(margin=config.shield.margin), robot)
    policy = MixtureOfExpertsPolicy(
        knowledge,
        perception,
        seeds,
        config.experts,
        reflex,
        config.update.temperature0,
        options,
        shield,
    )
    if states is not None:
        policy.load_robot_states(states)
    return policy


def build_update(config: RunConfig, policy: MixtureOfExpertsPolicy) -> TeseoUpdate:
    """The TESEO update of ``policy``'s experts with ``config``'s sections."""
    from symrl.learner.update import TeseoUpdate

    return TeseoUpdate(
        policy, config.update, config.trial_gradient, config.env.robot, config.env.max_actions
    )


def assemble(
    config: RunConfig,
    seeds: Sequence[int],
    world: Any = None,
    check: Callable[[RunConfig, int, WorldMap], Any] | None = None,
) -> Assembly:
    """A training run of one robot per seed in ``world`` (a loaded map, a map name or None:
    ``env.map``): env (perception transform appended), policy told ``config.knowledge`` of the
    world, a collector drawing exploration noise, and the update. ``check(config, batch,
    world)`` is called before the policy allocates its experts (the memory check)."""
    from torchrl.envs.utils import ExplorationType

    from symrl.collector import StepCollector

    env = make_env(config, seeds, world=world)
    config = with_budget(config, env)
    if check is not None:
        check(config, len(seeds), env.world)
    policy = build_policy(config, env.world, seeds)
    # what the robot makes of each observation, written once on reset and step
    env = env.append_transform(policy.perception_transform())
    # one step of the B robots per batch; the policy draws its exploration noise
    collector = StepCollector(env, policy, exploration_type=ExplorationType.RANDOM)
    return Assembly(config, env, policy, build_update(config, policy), collector)


def assemble_greedy(
    config: RunConfig,
    knowledge: Knowledge | WorldMap | None,
    states: Sequence[dict[str, Any]],
    seeds: Sequence[int],
    world: Any = None,
    starts: Any = None,
    subgoals: SubgoalTable | None = None,
    env_seeds: Sequence[int] | None = None,
) -> tuple[MixtureOfExpertsPolicy, Any]:
    """Greedy trials of controllers ``states`` (robot b: ``states[b]``, noise seed
    ``seeds[b]``), told ``knowledge`` (what they learned in, cut to ``config.knowledge``), on
    an env of ``world`` (the world they drive in; default: ``env.map``) from ``starts`` (B, 3)
    (default: the map's start), its robots seeded ``env_seeds`` (default ``seeds``). The
    policy and the env (its perception transform appended); no collector, no update."""
    policy = build_policy(config, knowledge, seeds, subgoals, states)
    env_seeds = seeds if env_seeds is None else env_seeds
    env = make_env(config, env_seeds, world=world, starts=starts)
    return policy, env.append_transform(policy.perception_transform())
