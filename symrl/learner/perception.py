"""What the robot makes of an observation, as a TorchRL env transform.

Once per observation (on reset, partial resets included, and on step), from what the robot is
told (its :class:`~symrl.knowledge.rungs.Knowledge`) and its config:

- ``pose`` (B, 3): the pose it believes, the odometry's, or the odometry corrected by matching
  each scan against one read a few actions before (``symrl.knowledge.scan_odometry``), or, with
  map localisation, the pose its sonar scan gives in the map (``symrl.knowledge.localize``,
  warm-started along each trial);
- ``belief_goal`` (B, 2): the goal's (distance, angle) from that pose;
- ``region`` (B,): the map region of that pose by the region rules; ``expert`` (B,): the
  expert it gates to (the region with partition, else 0);
- ``x`` (B, D): the experts' input, (sonars, goal-distance codes) (Eq. 2) or the pose input;
- ``is_init`` (B, 1) bool, as TorchRL's ``InitTracker`` writes it: True on the first
  observation of a trial (the robots a reset restarted), False after a step. The policy
  forgets a robot's per-trial decisions there, so the loop needs no call into it between two
  trials. Written by the env transform only (a direct call does not know a trial's start).

The transform is part of the agent, not of the world: the assembly (:mod:`symrl.assembly`)
builds it from what the robot is told, appends it to the batched env and hands it to the
policy; the policy and the update read its keys (root: the state acted in; ``"next"``: the
state reached). It takes the config sections it uses: the robot's (``env.robot``),
``experts`` (the input and its codes), ``localize``, the gate's ``partition`` and
``scan_odometry``.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Categorical, Composite, Unbounded
from torchrl.envs.transforms import Transform

from symrl.knowledge.localize import MapLocalizer, PoseTracker
from symrl.knowledge.regions import RegionMapper
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.scan_odometry import ScanOdometry
from symrl.learner.config import ExpertsConfig, LocalizeSection, ScanOdometrySection
from symrl.tensordicts import read, write
from symrl.world.geometry import Walls
from symrl.world.physics import goal_reading
from symrl.world.robot import RobotConfig

__all__ = ["Perception", "PERCEPTION_KEYS", "INIT_KEY"]

PERCEPTION_KEYS = ("pose", "belief_goal", "region", "expert", "x")
INIT_KEY = "is_init"


def _tracker(
    knowledge: Knowledge,
    batch: int,
    robot: RobotConfig,
    localize: LocalizeSection,
    scan_odometry: ScanOdometrySection | None,
) -> PoseTracker | ScanOdometry | None:
    """Where the believed pose comes from: the map localiser (told the map), the scan odometry,
    or None (the odometry as observed)."""
    if localize.enabled:
        walls = Walls(knowledge.geometry("localize").segments)
        localizer = MapLocalizer(
            walls,
            robot,
            localize.iterations,
            localize.prior_xy,
            localize.prior_heading,
            max_move=localize.max_move,
            outlier=localize.outlier,
        )
        return PoseTracker(localizer, batch)
    if scan_odometry is not None and scan_odometry.enabled:
        return ScanOdometry(
            robot,
            batch,
            scan_odometry.keyframe_actions,
            scan_odometry.iterations,
            scan_odometry.outlier,
        )
    return None


class Perception(Transform):
    """The robot's perception of B observations (see the module docstring), written into the
    TensorDict by a TorchRL env (``env.append_transform(perception)``) or by a direct call
    (``perception(td)``: a saved observation perceived again, as a resumed run does)."""

    def __init__(
        self,
        knowledge: Knowledge,
        batch: int,
        robot: RobotConfig,
        experts: ExpertsConfig,
        localize: LocalizeSection,
        partition: bool,
        scan_odometry: ScanOdometrySection | None = None,
    ) -> None:
        """B = ``batch`` robots told ``knowledge``, with the sections ``env.robot``,
        ``experts``, ``localize``, ``gate.partition`` and ``scan_odometry`` (None: off) of
        their config."""
        super().__init__(
            in_keys=["sonar", "odometry", "goal"], out_keys=[*PERCEPTION_KEYS, INIT_KEY]
        )
        xc = experts
        self.batch = batch
        self.goal = (float(knowledge.goal.x), float(knowledge.goal.y))
        self.tracker = _tracker(knowledge, batch, robot, localize, scan_odometry)
        self.mapper = RegionMapper(knowledge.regions)
        self.partition = bool(partition)
        self.pose_input = xc.input == "pose"
        self.heading_scale = float(xc.heading_scale)
        self.code_width = float(xc.goal_code_width)
        self.input_dim = 4 if self.pose_input else robot.n_sensors + xc.goal_codes
        n = xc.goal_codes
        self.code_centres = torch.arange(n, dtype=torch.float32) / (n - 1)
        start, goal = knowledge.start, knowledge.goal
        self.start_distance = max(math.hypot(start.x - goal.x, start.y - goal.y), 1e-9)

    # -- what the robot makes of an observation --------------------------------------------
    def belief(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The pose the robot steers by and the goal's (distance, angle) from it: the odometry's
        as observed, or corrected by its scans (scan odometry), or with map localisation the
        pose its sonar scan gives in the map."""
        if self.tracker is None:
            return odometry, goal
        pose = self.tracker(odometry.numpy(), sonar.numpy())
        seen = goal_reading(self.goal[0], self.goal[1], pose[:, 0], pose[:, 1], pose[:, 2])
        return torch.from_numpy(pose.astype(np.float32)), torch.from_numpy(seen)

    def encode(self, sonar: torch.Tensor, goal_distance: torch.Tensor) -> torch.Tensor:
        """x = (sonars, goal-distance codes) (Eq. 2); rho clipped to [0, 1]."""
        rho = (goal_distance.to(torch.float32) / self.start_distance).clamp(0.0, 1.0)
        codes = torch.exp(-(((self.code_centres - rho[:, None]) / self.code_width) ** 2))
        return torch.cat((sonar, codes), dim=-1)

    def encode_pose(self, pose: torch.Tensor) -> torch.Tensor:
        """x = (x, y, h cos theta, h sin theta) of the pose, h = ``heading_scale``."""
        # numpy on the tensor's memory (four columns of a handful of rows); cos and sin stay
        # torch's, whose last bit differs from numpy's
        p = pose.numpy().astype(np.float32, copy=False)
        theta = torch.from_numpy(p[:, 2])
        x = np.empty((len(p), 4), dtype=np.float32)  # the four columns written in place
        x[:, :2] = p[:, :2]
        np.multiply(self.heading_scale, theta.cos().numpy(), out=x[:, 2])
        np.multiply(self.heading_scale, theta.sin().numpy(), out=x[:, 3])
        return torch.from_numpy(x)

    def perceive(
        self, sonar: torch.Tensor, odometry: torch.Tensor, goal: torch.Tensor
    ) -> dict[str, torch.Tensor]:
        """The perception keys of a batch of observations."""
        pose, seen = self.belief(sonar, odometry, goal)
        region = torch.from_numpy(self.mapper.ids_np(pose.numpy()[:, :2].astype(np.float64)))
        expert = region if self.partition else torch.zeros_like(region)
        x = self.encode_pose(pose) if self.pose_input else self.encode(sonar, seen[:, 0])
        return {"pose": pose, "belief_goal": seen, "region": region, "expert": expert, "x": x}

    def summary(self, row: int) -> dict[str, float]:
        """Robot ``row``'s last finished trial as its pose tracker saw it, for its trial record
        (the scan odometry's correction; nothing for the odometry or the map localiser)."""
        return self.tracker.summary(row) if isinstance(self.tracker, ScanOdometry) else {}

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a new trial: their localisation starts afresh."""
        if self.tracker is not None:
            self.tracker.begin_trial(rows)

    # -- the transform ----------------------------------------------------------------------
    def _write(self, td: TensorDictBase, init: np.ndarray | None = None) -> TensorDictBase:
        """The perception keys of ``td``'s observations written into it, and ``is_init`` if
        ``init`` (B, 1) is given."""
        seen = self.perceive(read(td, "sonar"), read(td, "odometry"), read(td, "goal"))
        if init is not None:
            seen[INIT_KEY] = torch.from_numpy(init)
        return write(td, seen)

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        return self._write(tensordict)

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        # a tensor of its own every step: a masked reset may fill the old one in place
        return self._write(next_tensordict, np.zeros((self.batch, 1), dtype=bool))

    def _reset(
        self, tensordict: TensorDictBase | None, tensordict_reset: TensorDictBase
    ) -> TensorDictBase:
        mask = None if tensordict is None else tensordict.get("_reset", None)
        rows = (
            np.arange(self.batch)
            if mask is None
            else np.flatnonzero(mask.reshape(self.batch).numpy())
        )
        self.begin_trial(rows)
        init = np.zeros((self.batch, 1), dtype=bool)
        init[rows] = True
        return self._write(tensordict_reset, init)

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        shape = observation_spec.shape
        observation_spec["pose"] = Unbounded((*shape, 3), dtype=torch.float32)
        observation_spec["belief_goal"] = Unbounded((*shape, 2), dtype=torch.float32)
        observation_spec["region"] = Unbounded(shape, dtype=torch.long)
        observation_spec["expert"] = Unbounded(shape, dtype=torch.long)
        observation_spec["x"] = Unbounded((*shape, self.input_dim), dtype=torch.float32)
        observation_spec[INIT_KEY] = Categorical(2, (*shape, 1), dtype=torch.bool)
        return observation_spec
