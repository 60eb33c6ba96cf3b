"""Typed run configuration: read and merged by OmegaConf, validated by pydantic.

A recipe (``recipes/<name>.yaml``) sets a few fields of :class:`RunConfig`; the defaults
are the literal rules of the paper (``docs/explanation/algorithm.md``), so a recipe lists only
what it changes. ``key=value`` overrides (``update.gamma=0.9``, each key once) are merged on top;
mappings merge entry by entry (``reflex.near`` keeps the sectors a recipe does not name), anything
else replaces. OmegaConf reads, parses and merges (so ``${shield.margin}`` refers to another key);
pydantic validates. Every error is one line naming the key and the value (:class:`ConfigError`).
The string under each field is its description (``symrl train --help-keys``).

The sections follow the data flow: ``env`` (world and robot) -> ``localize`` (the pose the
robot believes) -> ``gate`` (regions) ->
``experts`` (growing RBF networks) -> ``options`` (sub-goals for the reflex) -> ``reflex`` ->
``shield``; ``update`` is the TESEO learning rule,
``trial_gradient`` a second actor rule; ``run`` the budget.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, cast

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictInt,
    ValidationError,
    model_validator,
)

from symrl.knowledge.reflex import ReflexConfig
from symrl.knowledge.rungs import Rung, rung_at_least
from symrl.world.robot import RobotConfig

if TYPE_CHECKING:  # OmegaConf is imported where a recipe or an override is read (~40 ms)
    from omegaconf import DictConfig

__all__ = [
    "ConfigError",
    "EnvConfig",
    "GateConfig",
    "ExpertsConfig",
    "UpdateConfig",
    "TrialGradientConfig",
    "OptionsConfig",
    "OptionCriticConfig",
    "CrossingsConfig",
    "LocalizeSection",
    "ShieldSection",
    "RunSection",
    "RunConfig",
    "load_config",
    "builtin_recipes",
    "config_to_dict",
    "config_from_dict",
    "describe_keys",
    "apply_overrides",
]


class ConfigError(ValueError):
    """A recipe or override is malformed; the message names the key and the value."""


class _Section(BaseModel):
    # StrictBool / StrictInt fields: no silent "yes" -> True or 2.5 -> 2 coercion; the string
    # under each field is its description (``--help-keys``), here and in the dataclass sections
    model_config = ConfigDict(
        extra="forbid", validate_default=True, allow_inf_nan=False, use_attribute_docstrings=True
    )


class EnvConfig(_Section):
    """The simulated world and robot."""

    map: str = "hailu2001"
    """Built-in map name or path of a map YAML file."""
    noise: StrictBool = True
    """Sensor and motion noise on (False turns every noise source off)."""
    max_actions: StrictInt = Field(200, ge=1, le=100_000)
    """A trial is truncated (failed) after this many actions, on a world up to the paper's
    travel in size; a building gets more in proportion (``symrl.world.budget``)."""
    robot: RobotConfig = Field(default_factory=RobotConfig)
    """The B21 (body, sensors, noise levels): any ``RobotConfig`` field."""


class GateConfig(_Section):
    """The symbolic region gate (paper 6.1)."""

    partition: StrictBool = True
    """One expert per map region; False: one expert for the whole world (ablation)."""


class ExpertsConfig(_Section):
    """The growing RBF networks, one per region (paper 7-8)."""

    learning: StrictBool = True
    """False: no neurons and no updates, the reflex drives the robot (``reflex_only``)."""
    reflex: StrictBool = True
    """New neurons take the fuzzy reflex's action (paper 8.3); False: a uniform random action."""
    residual: StrictBool = False
    """Neurons learn a correction added to the reflex's current action (a new neuron's p = 0)
    instead of an absolute action copied from the reflex at its birth. Needs ``reflex``."""
    input: Literal["sensors", "pose"] = "sensors"
    """What a neuron's centre encodes. ``sensors``: the sonars and the goal-distance codes
    (paper 7.1). ``pose``: the odometry pose the region gate reads, (x, y, h cos theta,
    h sin theta) in metres with h = ``heading_scale``. A robot that repeats its path meets the
    same neurons again (with sensors, 46 % of steps grow a neuron: noise makes every sonar
    vector new), so far fewer neurons are grown and each is revisited; ``novelty_radius`` is
    then in metres."""
    heading_scale: float = Field(1.0, gt=0)
    """Metres one radian of heading counts for in the ``pose`` input."""
    width: float = Field(0.1, gt=0)
    """RBF receptive width (varsigma, paper 7.1); activations exp(-d^2 / width^2)."""
    novelty_radius: float = Field(0.1, gt=0)
    """Distance-driven growth: a new neuron when the winner is farther than this."""
    goal_codes: StrictInt = Field(8, ge=2, le=256)
    """Goal-distance codes phi_m = exp(-((mu_m - rho) / goal_code_width)^2), mu_m = m/(n-1)."""
    goal_code_width: float = Field(1.0, gt=0)
    """Width of the goal-distance codes; 1.0 is the paper's printed (unit-width) form."""
    capacity: StrictInt = Field(64, ge=1, le=1_000_000)
    """Neurons preallocated per expert; storage doubles when full (up to ``max_neurons``)."""
    max_neurons: StrictInt = Field(100_000, ge=1, le=1_000_000)
    """Hard limit of neurons per expert; growing past it raises an error."""


class UpdateConfig(_Section):
    """The TESEO update (paper 8.3): TD critic, REINFORCE actor, growth, replacement, cooling."""

    gamma: float = Field(0.95, ge=0, le=1)
    """Discount of the TD error delta = r + gamma * u_now - u_prev."""
    eta: float = Field(0.3, ge=0)
    """Utility learning rate: u_prev += eta * delta."""
    beta: float = Field(0.2, ge=0)
    """Exploration-mean rate (REINFORCE, sigma^2-scaled): mu += beta * delta * (xi - mu)."""
    kappa: float = Field(0.1, ge=0, le=1)
    """Centre shift toward the previous input when delta > 0: c += kappa * (x - c)."""
    error_threshold: float = Field(2.0, gt=0)
    """Error-driven growth: |delta| above this adds a neuron at the previous input instead."""
    temperature0: float = Field(0.3, ge=0)
    """Initial exploration temperature T(0), radians (Eq. 6)."""
    cooling: float = Field(0.85, gt=0, le=1)
    """Temperature factor after each trial: T <- max(temperature_min, cooling * T)."""
    temperature_min: float = Field(0.05, ge=0)
    """Temperature floor, radians."""
    replace_actions: StrictBool = True
    """After a goal-reaching trial with the best total so far, p <- action taken, mu <- 0."""


class TrialGradientConfig(_Section):
    """A second actor rule for the experts (``symrl.learner.trial_gradient``): after each trial,
    every neuron's exploration mean steps along the gradient of the trial's reward with respect
    to its correction, replayed through the robot's odometry, its sonar readings and the reflex
    (the reflex's feedback included; with absolute actions, ``experts.residual=false``, the
    actions do not follow the reflex and the gradient is the open-loop one). Off in the paper
    (rate 0)."""

    rate: float = Field(0.0, ge=0)
    """mu += clip(rate * dJ/dmu, +-max_step) per neuron and trial; 0 turns the rule off."""
    max_step: float = Field(0.02, gt=0)
    """Largest change of a neuron's mean in one trial, radians (the model is linearised)."""
    limit: float = Field(0.6, gt=0)
    """The means stay within +-limit radians."""
    step_cost: float = Field(3.0, ge=0)
    """Worth of one action fewer, in units of the trial's mean cost per action (the model's
    price of arriving later)."""


class OptionCriticConfig(_Section):
    """How the option critic's actor explores: which option a region gets at its first entry in
    a trial (``symrl.learner.option_critic``). What it chooses among is ``options``."""

    epsilon: float = Field(0.3, ge=0, le=1)
    """Probability of a random option at a region's first entry, first trial."""
    epsilon_decay: float = Field(0.8, ge=0, le=1)
    """epsilon is multiplied by this after every trial."""
    greedy_after: StrictInt = Field(12, ge=0)
    """From this many finished trials on, options are chosen greedily (0: never forced)."""
    try_untried: StrictBool = True
    """Every option is tried once before any greedy choice (its critic is unknown until then)."""
    critic: Literal["mean", "best"] = "mean"
    """Option critic: the mean return-to-go over its trials, or the best single one."""


class OptionsConfig(_Section):
    """Sub-goal options: per region, where the reflex's goal following steers (the goal, a point
    of a border or passage toward the goal's region, or told the map the route), chosen at the
    region's first entry in a trial by the option critic (``symrl.learner.options``)."""

    enabled: StrictBool = False
    """False: the reflex always steers at the goal (the paper)."""
    source: Literal["map", "passages", "rules"] = "map"
    """What the options are made of. ``rules`` (needs ``knowledge: regions``): per region the
    goal and a point of each border with a region no farther from the goal's
    (``symrl.knowledge.borders``). ``passages`` (needs ``knowledge: passages``): the same from
    the passages the robot is told of (where the regions really connect) instead of the rules'
    borders. ``map`` (needs ``knowledge: map``): the passages' options and the route, a point
    ``ahead`` metres along the shortest path re-planned from where the robot believes it is
    (``symrl.knowledge.route``)."""
    reach: float = Field(0.25, ge=0)
    """A sub-goal nearer than this (m, believed pose) is reached: aim at the goal for the visit.
    The route re-plans when no point of its path up to the aim lies this near."""
    ahead: float = Field(0.8, gt=0)
    """How far along the route's path (m) from the robot's nearest point it aims (``map``)."""
    region_limit: StrictInt | None = Field(None, ge=1)
    """A timeout: an option in force for this many actions of a trial in its region (its
    visits added up) is given up for the best option left, and not chosen again (the route is
    re-planned instead). None: no limit (the paper has none)."""
    start_turn_deg: float | None = Field(None, ge=0, le=180)
    """A trial's first action turns straight at its aim (up to 180 degrees, in place of the
    reflex) when the aim is more than this many degrees off the heading; null: the reflex
    turns, by at most its output peaks per action."""
    goal_lead_deg: float = Field(0.0, ge=0, le=180)
    """While a visit's sub-goal lies within this angle (degrees) of the goal's bearing, seen from
    the robot, the reflex steers at the goal itself; from the first step the sub-goal lies
    further off, at the sub-goal for the rest of the visit. The reward's heading term (f2) is
    measured against the goal's bearing, so heading at the goal while the sub-goal is nearly in
    line earns it at little cost to the route. 0: at the sub-goal from the region's entry."""


class CrossingsConfig(_Section):
    """Where each border can be crossed, learned by each robot from its own sonar readings,
    odometry and progress (``symrl.learner.crossings``), for options made of the region rules'
    borders (``options.source: rules``): a border option aims at a stretch of the border the
    robot has not found blocked, and a border found blocked is routed around."""

    enabled: StrictBool = False
    """False: a border option aims at one fixed point of it (``symrl.knowledge.borders``)."""
    resolution: float = Field(0.1, gt=0, le=1)
    """Bin width (m) of the evidence kept along each border's line."""


_SOURCE_RUNG = {"rules": "regions", "passages": "passages", "map": "map"}
"""The knowledge each ``options.source`` needs."""


class LocalizeSection(_Section):
    """Map localisation (``symrl.knowledge.localize``): the pose the robot steers by is the one
    that best explains its sonar scan in the map, near its odometry pose, instead of the
    odometry pose itself. The reward stays on the odometry (the paper's f2)."""

    enabled: StrictBool = False
    """False: the robot believes its odometry (the paper)."""
    iterations: StrictInt = Field(2, ge=1, le=20)
    """Gauss-Newton steps from the odometry pose at a trial's first observation (a reset puts
    the odometry on the true pose, so few are needed; an odometry that starts off by decimetres
    needs about 5); every later observation takes a single step from the odometry pose plus the
    last correction (the drift changes by millimetres per action)."""
    prior_xy: float = Field(0.5, gt=0)
    """Spread of the odometry's position error (m): how far a scan may move the pose."""
    prior_heading: float = Field(0.2, gt=0)
    """Spread of the odometry's heading error (rad)."""
    max_move: float = Field(0.1, gt=0)
    """The largest position change (m) of one Gauss-Newton step (a trust region: a larger step
    is scaled down to it, heading included). The drift moves the pose by millimetres per
    action; a scan whose readings the map explains weakly along a corridor's axis (a 45-degree
    corridor, `office`'s long corridor) otherwise lets one mispredicted ray throw the estimate
    metres along it."""


class ShieldSection(_Section):
    """The IR safety shield (``symrl.knowledge.shield``)."""

    enabled: StrictBool = False
    """Veto moves that would leave less than ``margin`` rim clearance (nearest safe turn)."""
    margin: float = Field(0.06, ge=0, le=1)
    """Smallest predicted rim clearance a shielded move may leave (m)."""


class RunSection(_Section):
    """Budget, seed and logging of one run."""

    trials: StrictInt = Field(20, ge=1, le=1_000_000)
    """Number of trials (the training budget; paper: 20 per set)."""
    seed: StrictInt = Field(0, ge=0, lt=2**63)
    """Seed of the run; the same seed gives the same trial table."""
    image_every: StrictInt = Field(5, ge=1)
    """Log the trajectory image to TensorBoard every this many trials (and the last one)."""


class RunConfig(_Section):
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
    run: RunSection = Field(default_factory=RunSection)

    @model_validator(mode="after")
    def _consistent(self) -> RunConfig:
        o = self.options
        for key, on, needed in (
            ("gate.partition", self.gate.partition, "regions"),
            ("options.enabled", o.enabled, _SOURCE_RUNG[o.source]),
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
        if self.crossings.enabled and o.enabled and o.source != "rules":
            raise ValueError(
                "crossings.enabled=true learns where the region rules' borders can be crossed: "
                f"it needs options.source=rules, got options.source={o.source} "
                "(or set crossings.enabled=false)"
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


# ---------------------------------------------------------------------------------------------
# Loading: OmegaConf reads the recipe file and the ``key=value`` overrides and merges them;
# pydantic fills in the defaults and validates. What is left here is the one-line error messages.


def builtin_recipes() -> list[str]:
    """Names of the recipes shipped in the top-level ``recipes/`` (the package
    ``symrl.recipes``)."""
    folder = resources.files("symrl.recipes")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def _recipe_path(recipe: str | Path) -> tuple[str, Path]:
    text = str(recipe)
    if text.endswith((".yaml", ".yml")) or "/" in text or Path(text).is_file():
        path = Path(text)
        if not path.is_file():
            raise ConfigError(f"recipe {text!r}: no such file")
        return path.stem, path
    path = Path(str(resources.files("symrl.recipes") / f"{text}.yaml"))
    if not path.is_file():
        raise ConfigError(
            f"recipe {text!r}: unknown; built-in recipes are {', '.join(builtin_recipes())} "
            "(or pass a YAML file path)"
        )
    return text, path


def _read_recipe(text: str, path: Path) -> DictConfig:
    """The recipe file as a mapping (OmegaConf's YAML loader refuses a key given twice)."""
    stat = path.stat()
    return _read_recipe_file(text, str(path.resolve()), stat.st_mtime_ns, stat.st_size)


MAX_RECIPE_BYTES = 256 * 1024
"""Largest recipe file read (the built-in ones are 1-5 KiB)."""


@functools.lru_cache(maxsize=64)
def _read_recipe_file(text: str, path: str, mtime_ns: int, size: int) -> DictConfig:
    """Kept while the file is unchanged: studies and tests load the same recipes many times,
    and merging never changes its inputs."""
    from omegaconf import DictConfig, ListConfig, OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    if size > MAX_RECIPE_BYTES:  # before reading it: a recipe sets a few dozen keys
        raise ConfigError(
            f"recipe {text!r}: {size / 2**20:.1f} MiB, far larger than a recipe (at most "
            f"{MAX_RECIPE_BYTES // 1024} KiB: a recipe sets a few dozen keys); is it the right "
            "file?"
        )
    try:
        data = OmegaConf.load(path)
    except yaml.MarkedYAMLError as err:
        where = f"line {err.problem_mark.line + 1}: " if err.problem_mark else ""
        problem = " ".join(str(err.problem or err).split())
        if "node expansion exceeds" in problem:  # OmegaConf's cap on nodes, aliases or not
            raise ConfigError(
                f"recipe {text!r}: too many entries (over 10,000 YAML nodes); a recipe sets a "
                "few dozen keys"
            ) from None
        raise ConfigError(f"recipe {text!r}: not valid YAML ({where}{problem})") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        problem = " ".join(str(err).split())
        raise ConfigError(f"recipe {text!r}: not valid YAML ({problem})") from None
    except OmegaConfBaseException as err:  # e.g. a malformed ${...}
        key = getattr(err, "full_key", None) or "config"
        raise ConfigError(f"recipe {text!r}: {key}: {_first_line(err)}") from None
    if not isinstance(data, DictConfig) or not data:
        shown = OmegaConf.to_container(data) if isinstance(data, ListConfig) else data
        raise ConfigError(f"recipe {text!r}: expected a non-empty mapping, got {shown!r}")
    empty = _empty_mapping(data, "")
    if empty is not None:
        raise ConfigError(
            f"recipe {text!r}: {empty}: an empty mapping changes nothing (mappings merge entry "
            "by entry); set its entries or leave it out"
        )
    return data


def _empty_mapping(data: Any, prefix: str) -> str | None:
    """The dotted key of the first empty mapping in ``data`` (None: there is none)."""
    for key, value in data.items():
        name = f"{prefix}{key}"
        if hasattr(value, "items"):
            if not value:
                return name
            inner = _empty_mapping(value, f"{name}.")
            if inner is not None:
                return inner
    return None


def _overrides(overrides: list[str] | tuple[str, ...]) -> list[tuple[str, str, DictConfig]]:
    """Each ``key=value`` as (text, dotted key, nested config); the value is read as YAML. A key
    given twice (or inside another given key) and the recipe's name are refused."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    out: list[tuple[str, str, DictConfig]] = []
    for text in overrides:
        if "=" not in text:
            raise ConfigError(f"override {text!r}: expected key=value, e.g. update.gamma=0.9")
        key, value = text.split("=", 1)
        key = key.strip()
        if not all(key.split(".")):
            raise ConfigError(f"override {text!r}: empty key")
        if key == "recipe":
            raise ConfigError(
                f"{text}: the recipe's name is not a key to override; name the recipe or its file"
            )
        for other, known, _ in out:
            if key == known or key.startswith(known + ".") or known.startswith(key + "."):
                raise ConfigError(f"{text}: {key} is already set by {other}; give each key once")
        try:
            out.append((text, key, OmegaConf.from_dotlist([f"{key}={value}"])))
        except yaml.YAMLError as err:
            problem = " ".join((getattr(err, "problem", None) or str(err)).split())
            raise ConfigError(f"{text}: not a valid YAML value ({problem})") from None
        except OmegaConfBaseException as err:  # e.g. a malformed ${...}
            raise ConfigError(f"{text}: {_first_line(err)}") from None
    return out


_ABSENT = object()


@functools.cache
def _mapping_fields() -> dict[str, dict[str, Any]]:
    """Every mapping field (``reflex.near``, ``reflex.sectors``) by dotted key, with its default
    entries: pydantic fills in a missing field but not a mapping's missing entries."""

    def walk(prefix: str, section: Any) -> dict[str, dict[str, Any]]:
        names = (
            [f.name for f in dataclasses.fields(section)]
            if dataclasses.is_dataclass(section)
            else list(type(section).model_fields)
        )
        out: dict[str, dict[str, Any]] = {}
        for name in names:
            value = getattr(section, name)
            if isinstance(value, BaseModel) or dataclasses.is_dataclass(value):
                out |= walk(f"{prefix}{name}.", value)
            elif isinstance(value, dict):
                out[f"{prefix}{name}"] = _plain(value)
        return out

    return walk("", RunConfig())


@functools.cache
def _mapping_defaults() -> DictConfig:
    """What the layers are merged over: the mapping fields' default entries (the rest of the
    defaults pydantic fills in; giving them to OmegaConf would only cost its time)."""
    from omegaconf import OmegaConf

    base = OmegaConf.create()
    for key, entries in _mapping_fields().items():
        OmegaConf.update(base, key, entries)
    return base


def _complete(data: dict[str, Any]) -> bool:
    """Whether merging ``data`` over the defaults changes nothing pydantic would not fill in:
    each mapping field it gives has every default entry (a checkpoint's config does), and no
    string of it is an interpolation."""
    for key, entries in _mapping_fields().items():
        given = _at(data, key, _ABSENT)
        if given is not _ABSENT and not (
            isinstance(given, dict) and entries.keys() <= given.keys()
        ):
            return False
    return "${" not in repr(data)


def _merge(layers: list[tuple[str, Any]]) -> dict[str, Any]:
    """``layers`` (source, data) merged in order: mappings merge entry by entry, anything else
    replaces (``reflex.near.FL=[0.1, 0.3]`` keeps the other sectors); ``${key}`` interpolations
    are resolved. Keys no layer names take their defaults when pydantic validates."""
    from omegaconf import OmegaConf
    from omegaconf.errors import (
        InterpolationKeyError,
        InterpolationResolutionError,
        OmegaConfBaseException,
    )

    datas = [data for _, data in layers]
    try:
        merged = OmegaConf.merge(_mapping_defaults(), *datas)
        try:
            out = OmegaConf.to_container(merged, resolve=True)
        except InterpolationKeyError:  # it may name a key no layer sets: over every default
            every = OmegaConf.create(config_to_dict(RunConfig()))
            merged = OmegaConf.merge(_mapping_defaults(), every, *datas)
            out = OmegaConf.to_container(merged, resolve=True)
    except InterpolationResolutionError as err:
        key = str(getattr(err, "full_key", "") or "")
        value = _at(OmegaConf.to_container(merged), key)
        raise ConfigError(f"{key or 'config'}={value!r}: {_first_line(err)}") from None
    except (OmegaConfBaseException, TypeError, ValueError):
        below: Any = OmegaConf.to_container(_mapping_defaults())
        for source, data in layers:  # which layer puts a list over a mapping or the reverse
            clash = _clash(below, _container(data))
            if clash is not None:
                key, value = clash
                shown = f"{source}: " if source.startswith("recipe ") else ""
                raise ConfigError(
                    f"{shown}{key}={value!r}: a mapping and a list cannot replace each other"
                ) from None
            below = OmegaConf.to_container(OmegaConf.merge(below, data))
        raise
    return cast("dict[str, Any]", out)


def _first_line(err: Exception) -> str:
    """OmegaConf's message without the lines of context it adds (``full_key: ...``)."""
    return " ".join(str(err).splitlines()[0].split()) if str(err) else type(err).__name__


def _container(data: Any) -> Any:
    from omegaconf import DictConfig, ListConfig, OmegaConf

    return OmegaConf.to_container(data) if isinstance(data, (DictConfig, ListConfig)) else data


def _clash(base: Any, data: Any, prefix: str = "") -> tuple[str, Any] | None:
    """The first key where ``data`` puts a mapping over a list or a list over a mapping."""
    if not isinstance(base, dict) or not isinstance(data, dict):
        return None
    for name, value in data.items():
        key, old = f"{prefix}{name}", base.get(name)
        if (
            isinstance(old, dict)
            and isinstance(value, list)
            or (isinstance(old, list) and isinstance(value, dict))
        ):
            return key, value
        found = _clash(old, value, key + ".")
        if found is not None:
            return found
    return None


def _at(data: Any, key: str, default: Any = None) -> Any:
    """The value at dotted ``key`` in nested mappings (``default`` where there is none)."""
    for part in key.split(".") if key else []:
        if not isinstance(data, dict) or part not in data:
            return default
        data = data[part]
    return data


def _unknown(key: str, value: Any) -> str:
    """``key=value: unknown key``, with the nearest field name of its section if one is close;
    a mapping of a single entry is shown as its dotted key."""
    leaf = ""
    while isinstance(value, dict) and len(value) == 1:
        name, value = next(iter(value.items()))
        leaf += f".{name}"
    shown = key + leaf if isinstance(value, dict) else f"{key}{leaf}={value!r}"
    parts = key.split(".")
    section = _at(config_to_dict(RunConfig()), ".".join(parts[:-1]))
    names = [f for f in section if f != "recipe"] if isinstance(section, dict) else []
    close = difflib.get_close_matches(parts[-1], names, n=1)
    hint = f"; did you mean {'.'.join([*parts[:-1], close[0]])}{leaf}?" if close else ""
    return f"{shown}: unknown key{hint} (`symrl train --help-keys` lists them all)"


def _one_line(err: ValidationError) -> tuple[str, str]:
    """The first pydantic error as (dotted key, ``key=value: reason``)."""
    first = err.errors()[0]
    key = ".".join(str(p) for p in first["loc"])
    value = first.get("input")
    reason = first["msg"].removeprefix("Value error, ")
    if first["type"] in ("extra_forbidden", "unexpected_keyword_argument"):
        return key, _unknown(key, value)
    if isinstance(value, dict) or not key:
        return key, f"{key or 'config'}: {reason}"
    return key, f"{key}={value!r}: {reason}"


class _NumberFault(Exception):
    """A number key given a boolean, a string or an overflowing value (``symrl.learner.strict``)."""


def _validate(
    layers: list[tuple[str, Any]], recipe: str | None, merged: dict[str, Any] | None = None
) -> RunConfig:
    """Merge ``layers`` over the defaults (unless ``merged`` is given) and validate; an error
    names the layer that set the bad key when it is a recipe file (an override's message
    already shows its key and value)."""
    merged = _merge(layers) if merged is None else merged
    if recipe is not None:
        merged["recipe"] = recipe
    from symrl.learner.strict import number_fault

    fault = number_fault(RunConfig, merged)  # no bool or string for a number, no 1e308
    try:
        if fault is not None:
            raise _NumberFault()
        return RunConfig.model_validate(merged)
    except ValidationError as err:
        key, message = _one_line(err)
    except _NumberFault:
        key, message = fault  # type: ignore[misc]
    for source, data in reversed(layers):
        if key and _at(_container(data), key, _ABSENT) is not _ABSENT:
            if source.startswith("recipe "):
                message = f"{source}: {message}"
            break
    raise ConfigError(message) from None


def config_from_dict(data: dict[str, Any], recipe: str | None = None) -> RunConfig:
    """Build a validated RunConfig from a nested dict merged over the defaults."""
    if not isinstance(data, dict):
        raise ConfigError(f"config: expected a mapping of sections, got {data!r}")
    if _complete(data):  # nothing to merge: pydantic fills in any missing field
        return _validate([("config", data)], recipe, merged=dict(data))
    return _validate([("config", data)], recipe)


def config_to_dict(config: RunConfig) -> dict[str, Any]:
    """The config as a plain nested dict (YAML, checkpoints, TensorBoard); tuples become lists,
    which :func:`config_from_dict` reads back."""
    return _plain(config.model_dump())


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def load_config(
    recipe: str | Path = "paper_literal", overrides: list[str] | tuple[str, ...] | None = None
) -> RunConfig:
    """Load a recipe by name or path and apply ``key=value`` overrides (dotted keys, each key
    once; values read as YAML)."""
    name, path = _recipe_path(recipe)
    data = _read_recipe(str(recipe), path)
    layers = [(f"recipe {str(recipe)!r}", data)]
    layers += [(text, nested) for text, _, nested in _overrides(overrides or [])]
    declared = "knowledge" in data
    config: RunConfig | None = None
    try:
        config = _validate(layers, recipe=str(data.get("recipe", name)))
    except ConfigError as err:  # a rung fault of a recipe that declares none: the missing key
        if declared or "needs knowledge=" not in str(err):
            raise
    if not declared:  # what the robot is told is never left to a default
        if config is not None:  # any fault of the map it names first, as a declared one's
            from symrl.world.worldmap import load_map

            load_map(config.env.map)
        raise ConfigError(
            f"recipe {str(recipe)!r}: no knowledge: key; every recipe declares what the robot "
            "is told (knowledge: sensors, regions, passages or map)"
        )
    assert config is not None
    return config


def apply_overrides(config: RunConfig, overrides: list[str] | tuple[str, ...]) -> RunConfig:
    """``config`` with ``key=value`` overrides applied (validated again)."""
    layers: list[tuple[str, Any]] = [("config", config_to_dict(config))]
    layers += [(text, nested) for text, _, nested in _overrides(overrides)]
    return _validate(layers, recipe=config.recipe)


def describe_keys(config: RunConfig | None = None) -> str:
    """Every config key with its value in ``config`` (the library default where a recipe changes
    it is shown beside it) and its description, from the schema: the string under each field
    (for ``symrl train [RECIPE] --help-keys``)."""
    config = config if config is not None else RunConfig()
    schema = RunConfig.model_json_schema()
    defs = schema.get("$defs", {})
    defaults = config_to_dict(RunConfig())
    rows = [
        f"Config keys of recipe {config.recipe!r}: key = value, then what it means. "
        "Override one as key=value."
    ]

    def section(field: dict[str, Any]) -> dict[str, Any] | None:
        ref = field.get("$ref") or next((f["$ref"] for f in field.get("allOf", [])), None)
        return defs[ref.rsplit("/", 1)[-1]] if ref else None

    def walk(prefix: str, properties: dict[str, Any], values: dict[str, Any]) -> None:
        nested = []
        for name, field in properties.items():
            key, inner = f"{prefix}{name}", section(field)
            doc = " ".join((field.get("description") or "").split())
            if inner is not None:  # a section: its keys after the plain ones
                doc = doc or " ".join(inner.get("description", "").split())
                nested.append((key, doc, inner["properties"], values[name]))
                continue
            default = _at(defaults, key)
            changed = f"  (default {default!r})" if values[name] != default else ""
            rows.append(f"  {key} = {values[name]!r}{changed}")
            if doc:
                rows.append(f"      {doc}")
        for key, doc, inner_properties, inner_values in nested:
            rows.append(f"{key}:" + (f"  {doc}" if doc else ""))
            walk(f"{key}.", inner_properties, inner_values)

    walk(
        "", {k: v for k, v in schema["properties"].items() if k != "recipe"}, config_to_dict(config)
    )
    return "\n".join(rows)
