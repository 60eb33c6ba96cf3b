"""Typed run configuration: recipes are YAML files, every knob is a documented dataclass field.

A recipe (``symrl/recipes/<name>.yaml``) sets a few fields of :class:`RunConfig`; the dataclass
defaults are the literal rules of ``research/ALGORITHM.md`` section 1-2, so a recipe only lists
what it changes. Command-line overrides (``learner.gamma=0.9``) are applied on top. Unknown keys
and ill-typed values raise :class:`ConfigError` naming the key and the value, never a bare
``TypeError``.

To add an improvement for the ``paper`` recipe: add a field (with a docstring under it and a
default that keeps the literal behaviour), read it where it matters, and set it in
``recipes/paper.yaml``. ``Literal[...]`` fields are checked against their allowed values.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import yaml

from symrl.knowledge.reflex import ReflexConfig

__all__ = [
    "ConfigError",
    "LearnerConfig",
    "EnvConfig",
    "RunSection",
    "RunConfig",
    "load_config",
    "builtin_recipes",
    "config_to_dict",
    "config_from_dict",
]


class ConfigError(ValueError):
    """A recipe or override is malformed; the message names the key and the value."""


@dataclass
class LearnerConfig:
    """The growing-RBF mixture of experts and its update (paper sections 7-8, ALGORITHM.md)."""

    width: float = 0.1
    """RBF receptive width (varsigma, paper 7.1); activations are exp(-d^2 / width^2)."""
    novelty_radius: float = 0.1
    """Distance-driven growth: a new neuron when the winner is farther (literal: = width)."""
    gamma: float = 0.95
    """Discount of the TD error delta = r + gamma * u_now - u_prev."""
    eta: float = 0.3
    """Utility learning rate: u_prev += eta * delta."""
    beta: float = 0.2
    """Exploration-mean rate (REINFORCE, sigma^2-scaled): mu += beta * delta * (xi - mu)."""
    kappa: float = 0.1
    """Centre shift toward the previous input when delta > 0: c += kappa * (x - c)."""
    error_threshold: float = 2.0
    """Error-driven growth: |delta| above this adds a neuron at the previous input instead."""
    temperature0: float = 0.3
    """Initial exploration temperature T(0), radians (Eq. 6)."""
    cooling: float = 0.85
    """Temperature factor applied after each trial: T <- max(T_min, cooling * T)."""
    temperature_min: float = 0.05
    """Temperature floor, radians."""
    capacity: int = 1024
    """Neurons preallocated per expert; storage doubles when full (up to max_neurons)."""
    max_neurons: int = 200_000
    """Hard limit of neurons per expert; growing past it raises a RuntimeError."""
    partition: bool = True
    """One expert per map region (the symbolic gate, paper 6.1); False: one expert for all."""
    reflex: bool = True
    """New neurons take the fuzzy reflex's action (paper 8.3); False: a uniform random action."""
    learning: bool = True
    """False: no neurons and no updates, the reflex drives the robot (reflex_only)."""
    goal_codes: int = 8
    """Goal-distance codes phi_m = exp(-((mu_m - rho) / goal_code_width)^2), mu_m = m/(n-1)."""
    goal_code_width: float = 1.0
    """Width of the goal-distance codes; 1.0 is the paper's printed (unit-width) form."""
    utility_init: Literal["reward", "zero", "discounted"] = "reward"
    """New neuron's utility: reward = r(state) (paper 8.3), zero, or discounted = r/(1-gamma)."""
    replace_actions: bool = True
    """After a goal-reaching trial with the best total so far, p <- action taken, mu <- 0 (8.3)."""
    # --- issue #4: sub-goal options and residual corrections (docs/LEARNING.md) -------------
    options: bool = False
    """Steer the reflex's goal following at a per-region sub-goal derived from the map's region
    lines (the door), chosen once per region and trial by an averaging critic and an
    epsilon-greedy actor (``symrl/learner/options.py``); False: always at the goal (literal)."""
    option_epsilon: float = 0.3
    """Probability of a random option at a region's first entry, first trial."""
    option_epsilon_decay: float = 0.8
    """option_epsilon is multiplied by this after every trial."""
    option_greedy_after: int = 12
    """From this many finished trials on, options are chosen greedily (0: never forced)."""
    option_try_untried: bool = True
    """Every option is tried once before any greedy choice (its critic is unknown until then)."""
    option_reach: float = 0.25
    """A sub-goal nearer than this (m, odometry) is reached: aim at the goal for the visit."""
    option_critic: Literal["mean", "best"] = "mean"
    """Option critic: mean return-to-go over its trials, or the best single one (literal-style)."""
    option_risk: float = 0.0
    """Greedy option score = mean - option_risk * sd of its returns (prefers steady options)."""
    option_collision_penalty: float = 0.0
    """Extra penalty per collision in the option critic's return only (rewards unchanged)."""
    subgoal_past: bool = True
    """A region also gets the points just past the passage it is entered through (keeps the
    robot off the far door post when it turns to the goal)."""
    subgoal_on_line: bool = True
    """Offer the sub-goals on a region line itself (the passage centre...); False: only the points
    0.4 m past the line (reaching a point on the line makes the robot turn to the goal while still
    in front of the door, into the post)."""
    subgoal_min_clearance: float = 0.0
    """Drop sub-goals closer than this to a wall (metres; 0 keeps all)."""
    option_avoidance: list[float] = field(default_factory=list)
    """Candidate desirabilities d_a of the reflex's obstacle avoidance, one chosen per region and
    trial by a second averaging critic with the sub-goal options' rules (first entry, mean
    return-to-go, epsilon-greedy). With the shield guarding the walls, a lower d_a cuts the
    reflex's zig-zag at the door and in the corridor. Empty: the reflex's own d_a. Needs
    ``options`` and ``reflex``."""
    shield: bool = False
    """Veto moves into walls with the IR ring (``symrl.knowledge.shield``): an action whose move
    would leave less than ``shield_margin`` rim clearance is replaced by the nearest safe angle.
    The paper uses the IR only for its emergency reversal after the fact."""
    shield_margin: float = 0.06
    """Smallest predicted rim clearance a shielded move may leave (m; a virtual collision is
    below 0.056)."""
    residual: bool = False
    """Neurons learn a correction added to the reflex's current action (a new neuron's p = 0)
    instead of an absolute action copied from the reflex at its birth; with options on, this
    keeps every neuron valid whichever sub-goal the reflex steers at. Needs ``reflex``."""


@dataclass
class EnvConfig:
    """The simulated world (``symrl/Hailu2001-v0``)."""

    map: str = "hailu2001"
    """Built-in map name or path of a map YAML file."""
    noise: bool = True
    """Sensor and motion noise on (False turns every noise source off)."""
    max_actions: int = 200
    """A trial is truncated (failed) after this many actions (SPEC 4)."""
    rotation_noise_deg: float = 0.5
    """Robot: std of the true rotation per action, degrees (odometry drift; RobotConfig)."""
    translation_noise: float = 0.01
    """Robot: std of the true translation as a fraction of the 0.20 m step (RobotConfig)."""
    sonar_noise_std: float = 0.01
    """Robot: std of the Gaussian sonar noise, metres (RobotConfig)."""
    sonar_cone_deg: float = 0.0
    """Robot: sonar beam aperture in degrees; 0 is a thin ray (SPEC 2 default)."""
    sonar_cone_rays: int = 5
    """Robot: sub-rays per sonar when ``sonar_cone_deg > 0`` (a reading is their minimum)."""
    perfect_odometry: bool = False
    """Robot: the odometry pose is the true pose (motion noise still moves the robot)."""

    def robot(self) -> dict[str, Any]:
        """The ``RobotConfig`` fields this section sets (passed to the env as ``robot=``)."""
        names = ("sonar_noise_std", "translation_noise", "rotation_noise_deg",
                 "sonar_cone_deg", "sonar_cone_rays", "perfect_odometry")  # fmt: skip
        return {name: getattr(self, name) for name in names}


@dataclass
class RunSection:
    """Budget, seed and logging of one training run."""

    trials: int = 20
    """Number of trials (the training budget; paper: 20 per set)."""
    seed: int = 0
    """Seed of torch, numpy and the env; the same seed gives the same trials table."""
    image_every: int = 5
    """Log the trajectory image to TensorBoard every this many trials (and the last one)."""


@dataclass
class RunConfig:
    """Everything a run needs; ``recipe`` is the name it was loaded from."""

    recipe: str = "paper_literal"
    """Name of the recipe (used in the run folder's name)."""
    learner: LearnerConfig = field(default_factory=LearnerConfig)
    """The learner and its update."""
    env: EnvConfig = field(default_factory=EnvConfig)
    """The world."""
    reflex: ReflexConfig = field(default_factory=ReflexConfig)
    """The fuzzy reflex (``symrl.knowledge.reflex``); defaults: ALGORITHM.md section 4. A recipe
    may set any field; ``near`` and ``sectors`` entries are merged into the defaults."""
    run: RunSection = field(default_factory=RunSection)
    """Budget, seed, logging."""

    def validate(self) -> RunConfig:
        """Check value ranges; raise ConfigError naming the first bad key."""
        lc = self.learner
        checks: list[tuple[str, Any, bool, str]] = [
            ("learner.width", lc.width, lc.width > 0, "> 0"),
            ("learner.novelty_radius", lc.novelty_radius, lc.novelty_radius > 0, "> 0"),
            ("learner.gamma", lc.gamma, 0 <= lc.gamma <= 1, "in [0, 1]"),
            ("learner.eta", lc.eta, lc.eta >= 0, ">= 0"),
            ("learner.beta", lc.beta, lc.beta >= 0, ">= 0"),
            ("learner.kappa", lc.kappa, 0 <= lc.kappa <= 1, "in [0, 1]"),
            ("learner.error_threshold", lc.error_threshold, lc.error_threshold > 0, "> 0"),
            ("learner.temperature0", lc.temperature0, lc.temperature0 >= 0, ">= 0"),
            ("learner.cooling", lc.cooling, 0 < lc.cooling <= 1, "in (0, 1]"),
            ("learner.temperature_min", lc.temperature_min, lc.temperature_min >= 0, ">= 0"),
            ("learner.capacity", lc.capacity, lc.capacity >= 1, ">= 1"),
            ("learner.max_neurons", lc.max_neurons, lc.max_neurons >= lc.capacity, ">= capacity"),
            ("learner.goal_codes", lc.goal_codes, lc.goal_codes >= 2, ">= 2"),
            ("learner.goal_code_width", lc.goal_code_width, lc.goal_code_width > 0, "> 0"),
            ("env.max_actions", self.env.max_actions, self.env.max_actions >= 1, ">= 1"),
            (
                "env.sonar_noise_std",
                self.env.sonar_noise_std,
                self.env.sonar_noise_std >= 0,
                ">= 0",
            ),
            (
                "env.translation_noise",
                self.env.translation_noise,
                self.env.translation_noise >= 0,
                ">= 0",
            ),
            (
                "env.rotation_noise_deg",
                self.env.rotation_noise_deg,
                self.env.rotation_noise_deg >= 0,
                ">= 0",
            ),
            (
                "env.sonar_cone_deg",
                self.env.sonar_cone_deg,
                0 <= self.env.sonar_cone_deg < 360,
                "in [0, 360)",
            ),
            (
                "env.sonar_cone_rays",
                self.env.sonar_cone_rays,
                self.env.sonar_cone_rays >= 1,
                ">= 1",
            ),
            ("run.trials", self.run.trials, self.run.trials >= 1, ">= 1"),
            ("learner.option_epsilon", lc.option_epsilon, 0 <= lc.option_epsilon <= 1, "in [0, 1]"),
            (
                "learner.option_epsilon_decay",
                lc.option_epsilon_decay,
                0 <= lc.option_epsilon_decay <= 1,
                "in [0, 1]",
            ),
            (
                "learner.option_greedy_after",
                lc.option_greedy_after,
                lc.option_greedy_after >= 0,
                ">= 0",
            ),
            ("learner.option_reach", lc.option_reach, lc.option_reach >= 0, ">= 0"),
            ("learner.option_risk", lc.option_risk, lc.option_risk >= 0, ">= 0"),
            (
                "learner.subgoal_min_clearance",
                lc.subgoal_min_clearance,
                lc.subgoal_min_clearance >= 0,
                ">= 0",
            ),
            ("learner.shield_margin", lc.shield_margin, lc.shield_margin >= 0, ">= 0"),
            (
                "learner.option_collision_penalty",
                lc.option_collision_penalty,
                lc.option_collision_penalty >= 0,
                ">= 0",
            ),
            ("run.image_every", self.run.image_every, self.run.image_every >= 1, ">= 1"),
            *(
                ("learner.option_avoidance", lc.option_avoidance, 0 <= d_a <= 1, "values in [0, 1]")
                for d_a in lc.option_avoidance
            ),
            (
                "learner.option_avoidance",
                lc.option_avoidance,
                not lc.option_avoidance or (lc.options and lc.reflex),
                "empty unless learner.options and learner.reflex are true",
            ),
        ]
        try:
            self.reflex.validate()
        except ValueError as err:
            raise ConfigError(f"reflex: {err}") from None
        for key, value, ok, rule in checks:
            numbers = value if isinstance(value, list) else [value]
            finite = all(math.isfinite(v) for v in numbers if isinstance(v, float))
            if not ok or not finite:
                raise ConfigError(f"{key}={value!r}: must be {rule}")
        return self


# ---------------------------------------------------------------------------------------------
# Loading: recipe file -> dict -> typed dataclasses, then key=value overrides.


def builtin_recipes() -> list[str]:
    """Names of the recipes shipped in ``symrl/recipes``."""
    folder = resources.files("symrl") / "recipes"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def _recipe_path(recipe: str | Path) -> tuple[str, Path]:
    text = str(recipe)
    if text.endswith((".yaml", ".yml")) or "/" in text or Path(text).is_file():
        path = Path(text)
        if not path.is_file():
            raise ConfigError(f"recipe {text!r}: no such file")
        return path.stem, path
    path = Path(str(resources.files("symrl") / "recipes" / f"{text}.yaml"))
    if not path.is_file():
        raise ConfigError(
            f"recipe {text!r}: unknown; built-in recipes are {', '.join(builtin_recipes())} "
            "(or pass a YAML file path)"
        )
    return text, path


def _coerce(key: str, value: Any, kind: Any) -> Any:
    """Return ``value`` as type ``kind`` or raise ConfigError naming ``key``."""
    origin = typing.get_origin(kind)
    if origin is Literal:
        allowed = typing.get_args(kind)
        if value not in allowed:
            raise ConfigError(f"{key}={value!r}: must be one of {', '.join(map(str, allowed))}")
        return value
    if origin is dict:  # e.g. reflex.near: a mapping, merged into the current one by the caller
        if not isinstance(value, dict):
            raise ConfigError(f"{key}={value!r}: expected a mapping")
        key_kind, value_kind = typing.get_args(kind)
        return {
            _coerce(f"{key}", k, key_kind): _coerce(f"{key}.{k}", v, value_kind)
            for k, v in value.items()
        }
    if origin is tuple:  # tuple[float, float] or tuple[str, ...]: a YAML list
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{key}={value!r}: expected a list")
        args = typing.get_args(kind)
        kinds = [args[0]] * len(value) if len(args) == 2 and args[1] is Ellipsis else list(args)
        if len(kinds) != len(value):
            raise ConfigError(f"{key}={value!r}: expected a list of {len(kinds)} values")
        pairs = enumerate(zip(value, kinds, strict=True))
        return tuple(_coerce(f"{key}[{i}]", v, k) for i, (v, k) in pairs)
    if origin is list:  # list[float]: a YAML list (or one number) of numbers
        items = value if isinstance(value, (list, tuple)) else [value]
        (item_kind,) = typing.get_args(kind)
        return [_coerce(f"{key}[{i}]", item, item_kind) for i, item in enumerate(items)]
    if kind is bool:
        if isinstance(value, bool):
            return value
    elif kind is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif kind is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if isinstance(value, str):  # YAML 1.1 reads "1e-3" as a string
            try:
                return float(value)
            except ValueError:
                pass
    elif kind is str:
        if isinstance(value, str):
            return value
    else:  # pragma: no cover - only reached if someone adds a field of a new type
        raise ConfigError(f"{key}: field type {kind!r} is not supported by the loader")
    raise ConfigError(f"{key}={value!r}: expected {kind.__name__}, got {type(value).__name__}")


def _apply(obj: Any, data: dict[str, Any], prefix: str) -> None:
    """Set the fields of dataclass ``obj`` from ``data`` (recursively), checking names and types."""
    if not isinstance(data, dict):
        raise ConfigError(f"{prefix or 'recipe'}={data!r}: expected a mapping of keys")
    hints = typing.get_type_hints(type(obj))
    names = {f.name for f in dataclasses.fields(obj)}
    for name, value in data.items():
        key = f"{prefix}{name}"
        if name not in names:
            shown = key if isinstance(value, dict) else f"{key}={value!r}"
            raise ConfigError(
                f"{shown}: unknown key {name!r}; known keys here: {', '.join(sorted(names))}"
            )
        current = getattr(obj, name)
        if dataclasses.is_dataclass(current):
            _apply(current, value, f"{key}.")
        elif isinstance(current, dict):  # merge: a recipe names only the entries it changes
            setattr(obj, name, {**current, **_coerce(key, value, hints[name])})
        else:
            setattr(obj, name, _coerce(key, value, hints[name]))


def _parse_override(text: str) -> tuple[list[str], Any]:
    if "=" not in text:
        raise ConfigError(f"override {text!r}: expected key=value, e.g. learner.gamma=0.9")
    key, raw = text.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError(f"override {text!r}: empty key")
    try:
        value = yaml.safe_load(raw) if raw.strip() else raw
    except yaml.YAMLError:
        value = raw
    return key.split("."), value


def config_from_dict(data: dict[str, Any], recipe: str = "custom") -> RunConfig:
    """Build a validated RunConfig from a nested dict (e.g. a saved ``config.yaml``)."""
    config = RunConfig(recipe=recipe)
    _apply(config, dict(data), "")
    return config.validate()


def config_to_dict(config: RunConfig) -> dict[str, Any]:
    """The config as a plain nested dict (for YAML, checkpoints and the TensorBoard table);
    tuples become lists, which ``config_from_dict`` reads back."""

    def plain(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: plain(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [plain(v) for v in value]
        return value

    return plain(dataclasses.asdict(config))


def load_config(
    recipe: str | Path = "paper_literal", overrides: list[str] | None = None
) -> RunConfig:
    """Load a recipe by name or path and apply ``key=value`` overrides (dotted keys)."""
    name, path = _recipe_path(recipe)
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as err:
        raise ConfigError(f"recipe {str(path)!r}: not valid YAML ({err})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"recipe {str(path)!r}: expected a mapping at the top, got {data!r}")
    data.setdefault("recipe", name)
    config = RunConfig()
    _apply(config, data, "")
    for text in overrides or []:
        parts, value = _parse_override(text)
        nested: Any = value
        for part in reversed(parts):
            nested = {part: nested}
        _apply(config, nested, "")
    return config.validate()
