"""The whole run's schema: :class:`RunConfig`, the sections it holds, the rules between them
(what each setting needs of the rung ``knowledge`` and of the robot), and its plain-dict form."""

from __future__ import annotations

from typing import Any

from pydantic import Field, model_validator

from symrl.knowledge.option_sources import option_source
from symrl.knowledge.reflex import ReflexConfig
from symrl.knowledge.rungs import Rung, rung_at_least
from symrl.learner.config.baselines import BaselineSection, baseline_fault
from symrl.learner.config.sections import (
    CrossingsConfig,
    EnvConfig,
    ExpertsConfig,
    GateConfig,
    LocalizeSection,
    OptionCriticConfig,
    OptionsConfig,
    RunSection,
    ScanOdometrySection,
    Section,
    ShieldSection,
    TrialGradientConfig,
    UpdateConfig,
)


class ConfigError(ValueError):
    """A recipe or override is malformed; the message names the key and the value."""


class RunConfig(Section):
    """Everything a run needs; ``recipe`` is the name it was loaded from."""

    recipe: str = "paper_literal"
    """Name of the recipe (used in run folder names)."""
    knowledge: Rung = "regions"
    """What the robot is told (``symrl.knowledge.rungs``): ``sensors`` (its reflex, sensors,
    odometry, start and goal), ``regions`` (+ the region rules: the paper) or ``map`` (+ walls,
    free-space polygon, planner, map localisation). The agent is built from this alone; a
    setting that needs a higher rung is an error."""
    env: EnvConfig = Field(default_factory=EnvConfig)
    localize: LocalizeSection = Field(default_factory=LocalizeSection)
    scan_odometry: ScanOdometrySection = Field(default_factory=ScanOdometrySection)
    gate: GateConfig = Field(default_factory=GateConfig)
    experts: ExpertsConfig = Field(default_factory=ExpertsConfig)
    update: UpdateConfig = Field(default_factory=UpdateConfig)
    trial_gradient: TrialGradientConfig = Field(default_factory=TrialGradientConfig)
    options: OptionsConfig = Field(default_factory=OptionsConfig)
    crossings: CrossingsConfig = Field(default_factory=CrossingsConfig)
    option_critic: OptionCriticConfig = Field(default_factory=OptionCriticConfig)
    reflex: ReflexConfig = Field(default_factory=ReflexConfig)
    """The fuzzy reflex: any ``ReflexConfig`` field; ``near``/``sectors`` entries merge."""
    shield: ShieldSection = Field(default_factory=ShieldSection)
    baseline: BaselineSection = Field(default_factory=BaselineSection)
    run: RunSection = Field(default_factory=RunSection)

    @model_validator(mode="after")
    def _consistent(self) -> RunConfig:
        fault = baseline_fault(self)
        if fault is not None:
            raise ValueError(fault)
        o = self.options
        for key, on, needed in (
            ("gate.partition", self.gate.partition, "regions"),
            ("options.enabled", o.enabled, option_source(o.source).rung),
            ("localize.enabled", self.localize.enabled, "map"),
        ):
            if on and not rung_at_least(self.knowledge, needed):
                what = (
                    f"options.source={o.source} (with options.enabled=true)"
                    if key == "options.enabled"
                    else f"{key}=true"
                )
                raise ValueError(
                    f"{what} needs knowledge={needed} or higher, but the recipe declares "
                    f"knowledge={self.knowledge}"
                )
        if self.scan_odometry.enabled and self.localize.enabled:
            raise ValueError(
                "scan_odometry.enabled=true and localize.enabled=true: the pose comes from one "
                "of them; turn one off"
            )
        if self.crossings.enabled and o.enabled and o.source != "rules":
            raise ValueError(
                "crossings.enabled=true learns where the region rules' borders can be crossed: "
                f"it needs options.source=rules, got options.source={o.source} "
                "(or set crossings.enabled=false)"
            )
        if o.region_limit_scale is not None and o.region_limit is None:
            raise ValueError(
                f"options.region_limit_scale={o.region_limit_scale} scales the timeout: it "
                "needs options.region_limit (an integer), got null"
            )
        if self.experts.residual and not self.experts.reflex:
            raise ValueError("experts.residual=true needs experts.reflex=true")
        robot = self.env.robot
        if self.reflex.n_rays != robot.n_sensors:
            raise ValueError(
                f"reflex.n_rays={self.reflex.n_rays} must equal env.robot.n_sensors="
                f"{robot.n_sensors} (the reflex reads the robot's sonars)"
            )
        if self.reflex.sonar_range != robot.sonar_range:
            raise ValueError(
                f"reflex.sonar_range={self.reflex.sonar_range} must equal "
                f"env.robot.sonar_range={robot.sonar_range} (the sonars are normalised by it)"
            )
        if self.shield.margin >= robot.ir_range:
            raise ValueError(
                f"shield.margin={self.shield.margin} must be below env.robot.ir_range="
                f"{robot.ir_range} (the shield sees walls only by their IR reflectance)"
            )
        if self.experts.max_neurons < self.experts.capacity:
            raise ValueError(
                f"experts.max_neurons={self.experts.max_neurons} must be >= "
                f"experts.capacity={self.experts.capacity}"
            )
        return self


def config_to_dict(config: RunConfig) -> dict[str, Any]:
    """The config as a plain nested dict (YAML, checkpoints, TensorBoard); tuples become lists,
    which :func:`config_from_dict` reads back."""
    return plain(config.model_dump())


def plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value
