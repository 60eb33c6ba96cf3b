"""The sections of a run's config, one per part of the robot and its learning (pydantic).

Every field's default is the paper's literal rule; the string under a field is its description
(``symrl train --help-keys``). :class:`symrl.learner.config.RunConfig` holds one of each.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, field_validator

from symrl.knowledge.option_sources import option_source
from symrl.world.robot import RobotConfig


class Section(BaseModel):
    # StrictBool / StrictInt fields: no silent "yes" -> True or 2.5 -> 2 coercion; the string
    # under each field is its description (``--help-keys``), here and in the dataclass sections
    model_config = ConfigDict(
        extra="forbid", validate_default=True, allow_inf_nan=False, use_attribute_docstrings=True
    )


class EnvConfig(Section):
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


class GateConfig(Section):
    """The symbolic region gate (paper 6.1)."""

    partition: StrictBool = True
    """One expert per map region; False: one expert for the whole world (ablation)."""


class ExpertsConfig(Section):
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


class UpdateConfig(Section):
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


class TrialGradientConfig(Section):
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


class OptionCriticConfig(Section):
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
    try_if_shorter: StrictBool = False
    """An option is tried (untried, with ``try_untried``) or drawn by the epsilon-greedy actor
    only while it could still make the trial shorter than the robot's shortest trial to the
    goal so far: the actions already taken plus the straight way to its point plus, told the
    map, the planned way from its point to the goal (else the straight way) must be fewer. A
    lower bound, so no option that could be better is skipped; on a building with many doors
    per region most are. Options with fixed points only (not with ``crossings``)."""
    critic: Literal["mean", "best"] = "mean"
    """Option critic: the mean return-to-go over its trials, or the best single one."""
    credit: Literal["last", "first"] = "last"
    """With ``crossings``, where the return-to-go of an option chosen more than once in a region
    in one trial (given up, then chosen again after another was) starts: at its last choice, or
    at its first. From the last, an option that stalled is credited only with the tail that
    finished the region, and the option that took over with the stall's cost."""


class OptionsConfig(Section):
    """Sub-goal options: per region, where the reflex's goal following steers (the goal, a point
    of a border or passage toward the goal's region, or told the map the route), chosen at the
    region's first entry in a trial by the option critic (``symrl.learner.options``)."""

    enabled: StrictBool = False
    """False: the reflex always steers at the goal (the paper)."""
    source: str = "map"
    """What the options are made of: an option source (``symrl.knowledge.option_sources``).
    ``rules`` (needs ``knowledge: regions``): per region the goal and a point of each border
    with a region no farther from the goal's (``symrl.knowledge.borders``). ``passages`` (needs
    ``knowledge: passages``): the same from the passages the robot is told of (where the regions
    really connect) instead of the rules' borders. ``map`` (needs ``knowledge: map``): the
    passages' options and the route, a point ``ahead`` metres along the shortest path
    re-planned from where the robot believes it is (``symrl.knowledge.route``). A source of
    your own: ``module.path:NAME``, a module that registers NAME when imported
    (docs/how-to/add-a-knowledge-source.md)."""
    reach: float = Field(0.25, ge=0)
    """A sub-goal nearer than this (m, believed pose) is reached: aim at the goal for the visit.
    The route re-plans when no point of its path up to the aim lies this near."""
    ahead: float = Field(0.8, gt=0)
    """How far along the route's path (m) from the robot's nearest point it aims (``map``)."""
    region_limit: StrictInt | None = Field(None, ge=1)
    """A timeout: an option in force for this many actions of a trial in its region (its
    visits added up) is given up for the best option left, and not chosen again (the route is
    re-planned instead). None: no limit (the paper has none)."""
    region_limit_scale: float | None = Field(None, gt=0)
    """With ``region_limit``: an option's limit is the actions the straight way from where the
    robot chose it to its aim takes (the distance over the step length), times this, when that
    is more than ``region_limit``. None: ``region_limit`` for every option."""
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
    remembered_way: StrictBool = False
    """With ``crossings``: steer along the best trial's way, pulled tight where the trial's own
    echoes left room, while the options chosen are that trial's and until the options' aim is
    in plain sight where the way leads too (``symrl.learner.remembered_way``). It steers over
    the crossings' options: without ``crossings.enabled`` (or ``options.enabled``) it is
    inert, as the crossings are without options. On in ``paper``: 24 tuning worlds 1.147 ->
    1.113 x optimum, the paper's world unchanged (docs/journal/regions-learner-results.md)."""
    way_past_sight: StrictBool = False
    """With ``remembered_way``: once a trial the options steered from plain sight ends longer
    than the way itself (its legs over the step, by a tenth and 3 actions), the robot takes its
    way again at each new region or option it meets on it, where a wall may hide the next
    region's aim (a thin wall across the goal's bearing past a door). Off: the options steer
    for the rest of the trial once their aim is in plain sight. On in ``paper``: the tuning
    suite 1.112 / 1.121 -> 1.087 / 1.090 x optimum (``tuning/partition_end`` 1.85 / 2.01 ->
    1.07 / 1.07), the paper's world the same trial for trial
    (docs/journal/crossings.md, "The way again past plain sight")."""
    way_per_start_option: StrictBool = False
    """With ``remembered_way``: one way per option of the region a trial starts in, each the
    best trial's that started with it, so a trial whose critic chose another start option than
    the best trial did still has a way of its own (off: one way, the best trial's, and a trial
    starting otherwise is steered by the options alone). A trial whose first option was given
    up is the way of both options. On in ``paper``: the tuning suite 1.087 / 1.090 -> 1.083 /
    1.088 x optimum, failed trials from trial 5 1 -> 0 (docs/journal/crossings.md, "One way
    per start option")."""
    way_spares_goal_search: StrictBool = False
    """With ``remembered_way`` and ``goal_scans``: a trial that took the way but drove through
    its believed goal without arriving (the drifted odometry; the goal scans then searched for
    it) is no miss of the way (two misses in a row leave the way to the options for a while):
    its extra actions say where the odometry drifted, not that the way is stale. On in
    ``paper``: the tuning suite 1.083 / 1.089 -> 1.083 / 1.087 x optimum, fresh seeds
    5005-5019 1.086 either way with failed trials from trial 5 6 -> 5
    (docs/journal/crossings.md, "A goal search is no miss of the way")."""
    goal_scans: StrictBool = False
    """Keep the scans read on arriving at the goal, and once the robot has driven onto its
    believed goal's disc and off it again without arriving (its odometry has drifted), steer
    at the arrival point its latest scan matches (``symrl.learner.goal_scans``)."""
    goal_scans_passing_by: StrictBool = False
    """With ``goal_scans``: a belief that came within the body and the reward's close distance
    of its goal's disc and went farther off again without arriving searches too (for 10
    actions after each such pass). The reflex
    holds the robot off a wall its drifted belief does not see, so the belief can pass beside
    its goal without entering the disc, and circle the room from then on. A goal found so is
    steered at only off the believed disc, within the drift the odometry can have gathered and
    in plain sight (from behind a wall the arrival's walls match as a mirror image). On in
    ``paper``: the tuning suite 1.083 / 1.087 either way; both trials `check` lost from trial
    10 end (docs/journal/crossings.md, "Passing beside the goal")."""
    goal_scans_within_drift: StrictBool = False
    """With ``goal_scans``: a belief within the drift its odometry can have gathered (two
    standard deviations of the robot's motion model after the trial's actions) of its goal's
    disc searches at every step, once that drift exceeds the disc's radius: the goal may be in
    sight before the belief reaches it, and found then the robot steers at it instead of
    driving onto its drifted belief. Held to the same checks as a search from beside. On in
    ``paper`` (docs/journal/crossings.md, "Searching within the drift")."""
    wall_follow: StrictBool = False
    """A robot whose believed positions stayed within 1 m for 40 actions (2 m for 80) is
    trapped: it follows the nearest wall until it is 1 m from the trap and sees the straight
    way to its aim clear, as a bug algorithm does (``symrl.learner.wall_follow``). On in
    ``paper``."""

    @field_validator("source")
    @classmethod
    def _known_source(cls, value: str) -> str:
        """A registered source, or ``module.path:NAME`` (imported here)."""
        option_source(value)
        return value


class CrossingsConfig(Section):
    """Where each border can be crossed, learned by each robot from its own sonar readings,
    odometry and progress (``symrl.learner.crossings``), for options made of the region rules'
    borders (``options.source: rules``): a border option aims at a stretch of the border the
    robot has not found blocked, and a border found blocked is routed around."""

    enabled: StrictBool = False
    """False: a border option aims at one fixed point of it (``symrl.knowledge.borders``)."""
    resolution: float = Field(0.1, gt=0, le=1)
    """Bin width (m) of the evidence kept along each border's line."""
    dead_ends: StrictBool = False
    """A stretch the robot crossed, was trapped beyond (``options.wall_follow``) and crossed
    back out of is taken that way again only when no other stretch of the border is left."""


class LocalizeSection(Section):
    """Map localisation (``symrl.knowledge.localize``): the pose the robot steers by is the one
    that best explains its sonar scan in the map, near its last belief moved by the odometry's
    increment, instead of the odometry pose itself. The reward stays on the odometry (the
    paper's f2)."""

    enabled: StrictBool = False
    """False: the robot believes its odometry (the paper)."""
    iterations: StrictInt = Field(2, ge=1, le=20)
    """Gauss-Newton steps from the odometry pose at a trial's first observation (a reset puts
    the odometry on the true pose, so few are needed; an odometry that starts off by decimetres
    needs about 5); every later observation takes a single step from the last belief moved by
    the odometry's increment (the drift changes by millimetres per action)."""
    prior_xy: float = Field(0.5, gt=0)
    """Spread of the prior's position error (m): how far a scan may move the pose from the
    prediction (the odometry at a trial's first observation, then the last belief moved by the
    odometry's increment)."""
    prior_heading: float = Field(0.2, gt=0)
    """Spread of the prior's heading error (rad)."""
    max_move: float = Field(0.1, gt=0)
    """The largest position change (m) of one Gauss-Newton step (a trust region: a larger step
    is scaled down to it, heading included). The drift moves the pose by millimetres per
    action; a scan whose readings the map explains weakly along a corridor's axis (a 45-degree
    corridor, `office`'s long corridor) otherwise lets one mispredicted ray throw the estimate
    metres along it."""
    outlier: float | None = Field(None, gt=0)
    """Readings the map mispredicts by more than this (m) get no weight (None: every reading
    counts, beyond 5 cm less). The sonar's noise is a centimetre and the drift millimetres per
    action, so a reading metres off is a ray the model sends through a gap the scan saw as
    wall, or the reverse; along a corridor of repeating doors a few of them otherwise drag the
    belief to the next door."""


class ScanOdometrySection(Section):
    """The odometry corrected by the robot's own scans (``symrl.knowledge.scan_odometry``):
    each scan matched against the one read a few actions before, the odometry's increment the
    match's prior. Reads only the robot's sonar and odometry, so any rung may use it; not with
    map localisation (``localize``), which gives the pose from the map instead."""

    enabled: StrictBool = False
    """False: the robot believes its odometry (the paper)."""
    keyframe_actions: StrictInt = Field(5, ge=1, le=50)
    """Actions between two kept scans (each later scan is matched against the last kept one):
    fewer add a match's error more often, more leave too little of the kept scan's walls in
    sight."""
    iterations: StrictInt = Field(4, ge=1, le=20)
    """Gauss-Newton steps of each match."""
    outlier: float = Field(0.5, gt=0, le=5)
    """A reading predicted farther off than this (m) by the kept scan's echoes is left out of
    the match (a wall one scan saw and the other did not, or a corner the kept echoes cut).
    ``paper`` uses 0.075: from the odometry's increment a reading of the same wall is
    predicted to within a few centimetres, and at 0.5 the corners' readings pulled the heading."""


class ShieldSection(Section):
    """The IR safety shield (``symrl.knowledge.shield``)."""

    enabled: StrictBool = False
    """Veto moves that would leave less than ``margin`` rim clearance (nearest safe turn)."""
    margin: float = Field(0.06, ge=0, le=1)
    """Smallest predicted rim clearance a shielded move may leave (m)."""


class RunSection(Section):
    """Budget, seed and logging of one run."""

    trials: StrictInt = Field(20, ge=1, le=1_000_000)
    """Number of trials (the training budget; paper: 20 per set)."""
    seed: StrictInt = Field(0, ge=0, lt=2**63)
    """Seed of the run; the same seed gives the same trial table."""
    image_every: StrictInt = Field(5, ge=1)
    """Log the trajectory image to TensorBoard every this many trials (and the last one)."""
