"""The deep-RL baselines' section of a run's config (``baseline``): which algorithm learns in
place of the paper's experts (SAC or PPO from TorchRL), the priors it is handed, and its
hyper-parameters; and the rules that tie it to the rest of the config.

A config whose ``baseline.algorithm`` is null is the paper's learner; one that names an
algorithm is a baseline (the recipes ``sac`` and ``ppo``), trained by the same ``symrl train``.
A baseline reads the ``env`` section, and with ``residual`` the ``reflex`` and
``shield.margin``; the paper learner's sections (gate, experts, options, ...) it has not.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, StrictBool, StrictInt

from symrl.learner.config.sections import Section

__all__ = ["BaselineSection", "SACSection", "PPOSection", "baseline_fault", "used_settings"]

DEFAULT_ENVS = {"sac": 1, "ppo": 8}
"""Robots a baseline steps together unless ``baseline.envs`` says: SAC as Stable-Baselines3
runs it (one env), PPO 8 (on-policy data from parallel envs, as CleanRL runs it)."""
MAX_ENVS = 1024
"""Most robots a baseline steps together: each holds its own world and buffers."""
DEFAULT_CORRECTION = 0.25
"""The residual's largest correction, a fraction of pi, unless ``baseline.correction`` says."""


class SACSection(Section):
    """SAC hyper-parameters (``baseline.algorithm: sac``): Stable-Baselines3's ``SAC`` defaults
    (the values of Haarnoja et al. 2018), none tuned on this task."""

    buffer_size: StrictInt = Field(1_000_000, ge=1, le=100_000_000)
    """Replay buffer capacity (transitions)."""
    batch_size: StrictInt = Field(256, ge=1, le=1_000_000)
    """Transitions per gradient step."""
    learning_starts: StrictInt = Field(100, ge=0)
    """Transitions with uniformly random control before the first update."""
    lr: float = Field(3e-4, gt=0)
    """Adam learning rate of actor, critics and temperature."""
    gamma: float = Field(0.99, ge=0, le=1)
    """Discount."""
    tau: float = Field(0.005, gt=0, le=1)
    """Polyak factor of the target Q-networks."""
    updates_per_step: StrictInt = Field(1, ge=1, le=1000)
    """Gradient steps per environment transition (update-to-data ratio)."""
    hidden: StrictInt = Field(256, ge=1, le=65_536)
    """Units per hidden layer (2 layers, ReLU) of actor and critics."""
    alpha_init: float = Field(1.0, gt=0)
    """Initial entropy temperature (learned; target entropy -1 = -dim(action))."""


class PPOSection(Section):
    """PPO hyper-parameters (``baseline.algorithm: ppo``): CleanRL's
    ``ppo_continuous_action.py`` defaults unless noted, none tuned on this task."""

    frames_per_batch: StrictInt = Field(2048, ge=1, le=10_000_000)
    """Env transitions per PPO update (CleanRL num_envs x num_steps); ``frames_per_batch /
    envs`` steps of each robot."""
    epochs: StrictInt = Field(10, ge=1, le=1000)
    """Passes over each batch (update_epochs)."""
    minibatch: StrictInt = Field(64, ge=1)
    """Transitions per gradient step (2048 / 32 minibatches)."""
    lr: float = Field(3e-4, gt=0)
    """Adam learning rate (constant; CleanRL anneals it over a fixed total budget)."""
    gamma: float = Field(0.99, ge=0, le=1)
    """Discount."""
    lmbda: float = Field(0.95, ge=0, le=1)
    """GAE lambda."""
    clip: float = Field(0.2, gt=0)
    """PPO clip epsilon."""
    entropy_coef: float = Field(0.0, ge=0)
    """Entropy bonus (CleanRL: 0)."""
    critic_coef: float = Field(0.5, ge=0)
    """Value-loss weight."""
    max_grad_norm: float = Field(0.5, gt=0)
    """Gradient clipping."""
    hidden: StrictInt = Field(64, ge=1, le=65_536)
    """Units per hidden layer (2 layers, tanh)."""


class BaselineSection(Section):
    """A deep-RL baseline in place of the paper's learner (``symrl.studies.baseline``): SAC or
    PPO from TorchRL on the same world, from scratch or handed the paper's priors."""

    algorithm: Literal["sac", "ppo"] | None = None
    """``sac`` or ``ppo``: a baseline learns; null: the paper's learner (every other recipe)."""
    residual: StrictBool = False
    """Act as the shielded fuzzy reflex steering at the goal plus a learned correction of at
    most ``correction`` x pi (residual RL); false: the network's action itself."""
    regions: StrictBool = False
    """Append the region id of the odometry pose (one-hot, from the region rules) to the
    observation. Needs ``knowledge: regions`` or higher."""
    correction: float | None = Field(None, gt=0, le=1)
    """Largest residual correction as a fraction of pi; null: 0.25 (45 degrees; the reflex's own
    turns reach 90). Only with ``residual``."""
    envs: StrictInt | None = Field(None, ge=1, le=MAX_ENVS)
    """Robots stepped together, robot k's world seeded ``run.seed`` (k = 0) or ``run.seed *
    1000 + k``; null: the algorithm's default (sac 1, ppo 8)."""
    sac: SACSection = Field(default_factory=SACSection)
    ppo: PPOSection = Field(default_factory=PPOSection)

    @property
    def robots(self) -> int:
        """Robots stepped together (``envs`` or the algorithm's default)."""
        assert self.algorithm is not None
        return self.envs if self.envs is not None else DEFAULT_ENVS[self.algorithm]

    @property
    def bound(self) -> float:
        """The residual's largest correction (``correction`` or its default)."""
        return self.correction if self.correction is not None else DEFAULT_CORRECTION

    def hyper(self) -> SACSection | PPOSection:
        """The algorithm's hyper-parameters."""
        return self.sac if self.algorithm == "sac" else self.ppo


_PAPER_ONLY = (
    ("gate.partition", "the region gate of the experts"),
    ("options.enabled", "sub-goal options"),
    ("localize.enabled", "map localisation"),
)


def baseline_fault(config: Any) -> str | None:
    """What is wrong between ``config.baseline`` and the rest of ``config`` (one line), if
    anything: a baseline's priors without an algorithm, a correction without the residual, the
    region one-hot below the rung that tells the regions, or a part of the paper's learner
    turned on for a baseline (it would be ignored)."""
    from symrl.knowledge.rungs import rung_at_least

    b = config.baseline
    if b.algorithm is None:
        for key, value in (
            ("residual", b.residual),
            ("regions", b.regions),
            ("correction", b.correction),
            ("envs", b.envs),
        ):
            if value not in (False, None):
                shown = "true" if value is True else value
                return (
                    f"baseline.{key}={shown}: only with baseline.algorithm sac or ppo (the "
                    "recipes sac and ppo); the paper's learner is set by the other sections"
                )
        return None
    if b.correction is not None and not b.residual:
        return (
            f"baseline.correction={b.correction:g}: only with baseline.residual=true (it "
            "bounds the residual's correction; without it it would be ignored)"
        )
    if b.regions and not rung_at_least(config.knowledge, "regions"):
        return (
            "baseline.regions=true needs knowledge=regions or higher, but the recipe declares "
            f"knowledge={config.knowledge}"
        )
    for key, what in _PAPER_ONLY:
        section, name = key.split(".")
        if getattr(getattr(config, section), name):
            return (
                f"{key}=true: baseline.algorithm={b.algorithm} learns without {what} (a part "
                f"of the paper's learner); set {key}=false"
            )
    return None


def used_settings(config: Any, tree: dict[str, Any]) -> dict[str, Any]:
    """The part of ``tree`` (``config`` as a plain dict) the run's learner reads: for the
    paper's learner all of it but the ``baseline`` section; for a baseline the recipe,
    knowledge, env, run and its own section with its algorithm's hyper-parameters only, and with
    the residual the reflex and the shield (what ``config.yaml`` records and ``--resume``
    checks)."""
    b = config.baseline
    if b.algorithm is None:
        return {k: v for k, v in tree.items() if k != "baseline"}
    keys = ["recipe", "knowledge", "env"]
    keys += ["reflex", "shield"] if b.residual else []
    out = {k: tree[k] for k in keys}
    other = "ppo" if b.algorithm == "sac" else "sac"
    out["baseline"] = {k: v for k, v in tree["baseline"].items() if k != other}
    out["run"] = tree["run"]
    return out
