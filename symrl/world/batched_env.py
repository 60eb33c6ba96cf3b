"""The training face of the world: a TorchRL ``EnvBase`` of B robots stepped together.

``BatchedWorldEnv`` wraps one :class:`~symrl.world.physics.RobotBatch` (the same physics as the
Gymnasium :class:`~symrl.world.env.Hailu2001Env`, which is its B = 1 face) with ``batch_size=[B]``.
Each robot has its own ``np.random.Generator``, so robot b's trajectory depends only on its seed
and its actions, never on B or on the other robots. Episodes end per robot; TorchRL's partial
resets (a ``"_reset"`` mask, as the Collector's ``step_and_maybe_reset`` sends) restart only the
robots concerned.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase, TransformedEnv

from symrl.fastpaths import (
    new_tensordict,
    read,
    tensordict_items,
    transform_reset,
    transform_step,
    write,
)
from symrl.world.physics import Readings, RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap, load_map

__all__ = ["BatchedWorldEnv", "BatchedTransformedEnv"]

_OBS_KEYS = ("sonar", "ir", "bumper", "odometry", "goal")


class BatchedWorldEnv(EnvBase):
    """B robots in one world, one TorchRL env with ``batch_size=[B]`` (CPU).

    Observation keys (leading dim B): ``sonar`` (B, n) f32 in [0, 1], ``ir`` (B, n) f32,
    ``bumper`` (B, 1) f32, ``odometry`` (B, 3) f32, ``goal`` (B, 2) f32 (as the Gymnasium env),
    ``state_reward`` (B, 1) f32 -- the reinforcement f1 + f2 of the state just reached: equal to
    ``reward`` after a step, the reset state's value after a reset (the learner needs the value of
    a trial's first state) --, ``collision`` and ``reached_goal`` (B, 1) bool, ``true_pose``
    (B, 3) f64. Action: ``Bounded(-pi, pi, (B, 1))`` f32, the rotation before the translation
    (clipped to [-pi, pi]; a non-finite value raises ValueError naming the robot). Reward (B, 1)
    f32; ``done``/``terminated``/``truncated`` (B, 1) bool (terminated = the TRUE centre in the
    goal circle, truncated = ``max_actions`` actions).

    Seeding: robot b's generator is ``np.random.default_rng(seeds[b])`` (the stream gymnasium's
    ``reset(seed=s)`` creates, so robot b matches ``Hailu2001Env`` reset with ``seed=seeds[b]``
    given the same actions), or ``default_rng(seed + b)`` after ``env.set_seed(seed)``; without
    either, fresh OS entropy. Resets never reseed a robot's stream.

    Start poses: the map's start, or per robot after ``env.set_starts(poses)`` ((B, 3), radians;
    ``None`` restores the map's start). ``env.physics`` is the underlying ``RobotBatch``.
    """

    def __init__(
        self,
        world: str | Path | WorldMap | dict[str, Any] = "hailu2001",
        size: int = 1,
        robot: RobotConfig | dict[str, Any] | None = None,
        noise: bool = True,
        max_actions: int = 200,
        seeds: Sequence[int] | None = None,
    ) -> None:
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"BatchedWorldEnv: size must be a positive integer, got {size!r}")
        robot = RobotConfig.coerce(robot)
        if not isinstance(noise, (bool, np.bool_)):
            raise ValueError(f"noise must be True or False, got {noise!r}")
        super().__init__(device="cpu", batch_size=torch.Size([size]))
        self.world: WorldMap = world if isinstance(world, WorldMap) else load_map(world)
        self.robot: RobotConfig = robot
        self.physics = RobotBatch(self.world, robot, size, bool(noise), max_actions)
        self.size = size
        if seeds is None:
            self._rngs = [np.random.default_rng() for _ in range(size)]
        else:
            seeds = list(seeds)
            if len(seeds) != size:
                raise ValueError(f"seeds: need {size} seeds, one per robot, got {len(seeds)}")
            self._rngs = [np.random.default_rng(s) for s in seeds]
        self._starts = self._map_starts()
        self._last: dict[str, np.ndarray] | None = None  # outputs of the last reset or step
        self._make_specs()
        # step_mdp's rule (step_and_maybe_reset): the keys it drops from a step's input, and
        # those it brings from "next" (in TorchRL's order: sorted, observations first)
        self._dropped_keys = frozenset(("next", "_reset", *self.done_keys, *self.reward_keys))
        self._next_keys = (*sorted(self.observation_keys), *sorted(self.done_keys))

    # --- configuration -------------------------------------------------------------------

    @property
    def rngs(self) -> list[np.random.Generator]:
        """One generator per robot (robot b draws all its noise from ``rngs[b]``)."""
        return self._rngs

    def set_starts(self, poses: np.ndarray | Sequence[Sequence[float]] | None) -> None:
        """Start poses of the following resets: (B, 3) (x, y, heading in radians), or ``None``
        for the map's start. Every pose is checked (free area, clearance above the radius)."""
        if poses is None:
            self._starts = self._map_starts()
            return
        starts = np.array(poses, dtype=np.float64)
        if starts.shape != (self.size, 3):
            raise ValueError(
                f"set_starts: poses must have shape ({self.size}, 3), got {starts.shape}"
            )
        self.physics.check_poses(starts)
        self._starts = starts

    RUN_STATE_KEYS = ("env_rngs", "physics", "last")
    """The keys of :meth:`run_state` (a run snapshot stores them beside its other entries)."""

    def run_state(self) -> dict[str, Any]:
        """Everything between two steps a run snapshot needs (tensors and plain Python values):
        every robot's world generator, physics state and the outputs of its last reset or step
        (a partial reset keeps the other robots' rows from them)."""
        return {
            "env_rngs": [rng.bit_generator.state for rng in self._rngs],
            "physics": {k: torch.from_numpy(v) for k, v in self.physics.state().items()},
            "last": {k: torch.from_numpy(np.array(v)) for k, v in (self._last or {}).items()},
        }

    def load_run_state(self, state: dict[str, Any]) -> None:
        """Go on from :meth:`run_state` (a fresh env of the same map, robots and seeds)."""
        for rng, saved in zip(self._rngs, state["env_rngs"], strict=True):
            rng.bit_generator.state = saved
        self.physics.load_state({k: v.numpy() for k, v in state["physics"].items()})
        self._keep({k: v.numpy().copy() for k, v in state["last"].items()})

    def _map_starts(self) -> np.ndarray:
        s = self.world.start
        return np.tile(np.array([s.x, s.y, s.heading]), (self.size, 1))

    def _make_specs(self) -> None:
        b, n = self.size, self.robot.n_sensors

        def box(low: np.ndarray, high: np.ndarray) -> Bounded:
            shape = (b, *low.shape)
            return Bounded(
                torch.from_numpy(np.broadcast_to(low, shape).copy()),
                torch.from_numpy(np.broadcast_to(high, shape).copy()),
                shape,
                dtype=torch.float32,
            )

        def flag() -> Categorical:
            return Categorical(2, (b, 1), dtype=torch.bool)

        bounds = self.physics.observation_bounds()
        self.observation_spec = Composite(
            **{key: box(*bounds[key]) for key in _OBS_KEYS},
            state_reward=Bounded(-4.0, 0.0, (b, 1), dtype=torch.float32),
            collision=flag(),
            reached_goal=flag(),
            true_pose=Unbounded((b, 3), dtype=torch.float64),
            shape=(b,),
        )
        assert self.observation_spec["sonar"].shape == (b, n)
        self.action_spec = Bounded(-math.pi, math.pi, (b, 1), dtype=torch.float32)
        self.reward_spec = Unbounded((b, 1), dtype=torch.float32)
        self.done_spec = Composite(done=flag(), terminated=flag(), truncated=flag(), shape=(b,))

    # --- EnvBase ---------------------------------------------------------------------------

    def _set_seed(self, seed: int | None) -> None:
        """Robot b gets ``np.random.default_rng(seed + b)`` (fresh entropy for ``None``)."""
        if seed is None:
            self._rngs = [np.random.default_rng() for _ in range(self.size)]
        else:
            self._rngs = [np.random.default_rng(int(seed) + b) for b in range(self.size)]

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        mask = None if tensordict is None else tensordict.get("_reset", None)
        return self._tensordict(self._reset_arrays(mask))

    def _reset_arrays(self, mask: torch.Tensor | None) -> dict[str, np.ndarray]:
        """The reset's outputs of every robot as numpy arrays (``mask``: the robots to restart,
        None for all)."""
        if mask is None or self._last is None:
            rows = np.arange(self.size)
        else:
            rows = np.flatnonzero(mask.reshape(self.size).cpu().numpy())
            if len(rows) == 0:
                return self._last
        r = self.physics.reset(rows, self._starts[rows], self._rngs)
        out = self._arrays(r)
        out.pop("reward")
        for key in ("done", "terminated", "truncated"):
            out[key] = np.zeros((len(rows), 1), dtype=bool)
        if len(rows) < self.size:  # the other robots keep their last outputs
            assert self._last is not None
            merged = {}
            for key, value in out.items():
                full = self._last[key].copy()
                full[rows] = value
                merged[key] = full
            out = merged
        self._keep(out)
        return out

    def append_transform(self, transform: Any) -> BatchedTransformedEnv:
        """This env behind ``transform`` (TorchRL's ``append_transform``): a
        :class:`BatchedTransformedEnv`, whose control-loop step keeps this env's own."""
        return BatchedTransformedEnv(self, transform)

    def step_and_maybe_reset(
        self, tensordict: TensorDictBase
    ) -> tuple[TensorDictBase, TensorDictBase]:
        """Step, then start the next step's TensorDict and restart the robots that are done:
        TorchRL's ``EnvBase.step_and_maybe_reset`` with the same result (``tests/world`` holds
        them equal) for the control loop's input, a plain TensorDict of tensors without
        ``"next"`` or ``"_step"`` (anything else takes TorchRL's path). This env's ``_step``
        already gives every done key at its spec's shape, so the generic post-processing of
        the step's output has nothing to do, and the next TensorDict is the rule TorchRL's
        ``step_mdp`` applies, written out: every key of the input but ``"next"``, the reward
        and done keys and ``"_reset"`` (the action and the policy's outputs are kept), then
        the observation and done keys of ``"next"``. The generic step and step_mdp walk the
        specs and every key through checked accessors: about a fifth of the loop around the
        physics at B = 10 (measured: ``benchmarks/bench_train.py``). It runs eagerly: a
        ``compile()``d step_and_maybe_reset of TorchRL is not used by this env."""
        root = tensordict_items(tensordict, self.batch_size)
        if root is None or "next" in root or "_step" in root:
            return super().step_and_maybe_reset(tensordict)
        return self.step_and_reset_entries(tensordict, root)

    def step_and_reset_entries(
        self, tensordict: TensorDictBase, root: dict[str, torch.Tensor]
    ) -> tuple[TensorDictBase, TensorDictBase]:
        """:meth:`step_and_maybe_reset` of a TensorDict checked for its fast path (``root``:
        its entries)."""
        nxt = self._step(tensordict)
        write(tensordict, {"next": nxt})
        carried = {key: value for key, value in root.items() if key not in self._dropped_keys}
        carried.update((key, read(nxt, key)) for key in self._next_keys)
        done = read(nxt, "done")
        restarted = done.numpy().reshape(self.size)
        if restarted.any():  # maybe_reset's values, without writing the TensorDict twice
            carried = self._restarted(carried, done, restarted)
        following = new_tensordict(carried, self.batch_size, self.device)
        return tensordict, following

    def maybe_reset(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Restart the robots that are done (what ``step_and_maybe_reset`` calls after a step):
        TorchRL's ``EnvBase.maybe_reset`` with the same result (``tests/world`` holds them
        equal), without its generic masked merge of every key. This env's reset output already
        holds every robot's row (the others keep their last outputs, which ``tensordict``
        holds), so its tensors replace the old ones; a key the reset does not write (the
        action) reads 0 on the restarted rows, as in TorchRL's merge (``pad=0``). The merge
        was about half the cost of a partial reset (measured: ``benchmarks/bench_train.py``)."""
        done = read(tensordict, "done")
        restarted = done.numpy().reshape(self.size)
        if not restarted.any():
            return tensordict
        tensors = {}
        for key in list(tensordict.keys()):
            value = read(tensordict, key)
            if type(value) is torch.Tensor:
                tensors[key] = value
            else:  # a nested TensorDict: TorchRL's masked fill
                rows = torch.from_numpy(restarted).view(-1, *([1] * (value.dim() - 1)))
                tensordict.set(key, value.masked_fill(rows, 0))
        # TorchRL's unchecked setter (symrl.tensordicts): a partial reset writes every key of
        # the batch (about 25 of them)
        return write(tensordict, self._restarted(tensors, done, restarted))

    def _restarted(
        self, values: dict[str, torch.Tensor], done: torch.Tensor, restarted: np.ndarray
    ) -> dict[str, torch.Tensor]:
        """``values`` (every key of a batch) with the robots ``restarted`` reset: the reset's
        outputs replace their keys, every other key reads 0 on the restarted rows (new
        tensors, in numpy on the tensors' memory; ``values``' tensors are left as they were)."""
        reset = self._reset_arrays(done)
        out = {}
        for key, value in values.items():
            fresh = reset.get(key)
            if fresh is not None:
                out[key] = torch.from_numpy(fresh)
            else:
                zeroed = value.numpy().copy()
                zeroed[restarted] = 0
                out[key] = torch.from_numpy(zeroed)
        out.update((key, torch.from_numpy(value)) for key, value in reset.items() if key not in out)
        return out

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = read(tensordict, "action")
        if action.requires_grad:
            action = action.detach()
        if not action.is_floating_point() or action.numel() != self.size:
            raise ValueError(
                f"action: expected {self.size} float rotation(s) in radians, shape "
                f"({self.size}, 1), got {action.dtype} of shape {tuple(action.shape)}"
            )
        alpha = action.cpu().numpy().reshape(self.size)  # float32; widened exactly
        r = self.physics.step(alpha, self._rngs)
        out = self._arrays(r)
        out["terminated"] = r.reached_goal.reshape(-1, 1).copy()
        out["truncated"] = r.truncated.reshape(-1, 1)
        out["done"] = out["terminated"] | out["truncated"]
        self._keep(out)
        return self._tensordict(out)

    def _keep(self, out: dict[str, np.ndarray]) -> None:
        """Remember the outputs of this reset or step. Set past ``nn.Module.__setattr__`` (an
        EnvBase is a module: its setter looks the name up among parameters, buffers and
        submodules, about 5 us a batch step in the training loop); ``_last`` is none of them."""
        object.__setattr__(self, "_last", out)

    # --- internals -------------------------------------------------------------------------

    def _arrays(self, r: Readings) -> dict[str, np.ndarray]:
        """Numpy outputs of one reset or step (rows of ``r``); torch shares their memory."""
        # (k, 1) by reshape, not [:, None]: numpy gives a new axis stride 0, which some torch
        # kernels (torch.stack(..., out=) in the Collector) cannot take
        reward = r.reward.astype(np.float32).reshape(-1, 1)
        return {
            "sonar": r.sonar,
            "ir": r.ir,
            "bumper": r.bumper,
            "odometry": r.odometry,
            "goal": r.goal,
            "state_reward": reward,
            "reward": reward.copy(),
            "collision": r.collision.reshape(-1, 1),
            "reached_goal": r.reached_goal.reshape(-1, 1),
            "true_pose": r.true_pose,
        }

    def _tensordict(self, out: dict[str, np.ndarray]) -> TensorDictBase:
        """The output TensorDict, built directly (no per-key spec encoding: the hot loop)."""
        return new_tensordict(
            {key: torch.from_numpy(value) for key, value in out.items()},
            self.batch_size,
            self.device,
        )


class BatchedTransformedEnv(TransformedEnv):
    """A :class:`BatchedWorldEnv` behind transforms (TorchRL's ``TransformedEnv``) whose
    ``step_and_maybe_reset`` takes the base env's own (``BatchedWorldEnv.step_and_maybe_reset``)
    for the control loop's plain TensorDicts: the transforms' step on ``"next"``, their keys
    carried to the next TensorDict as ``step_mdp`` carries observations, and, when robots
    restarted, the transforms' reset on the next TensorDict with their ``"_reset"`` mask. The
    same result as TorchRL's generic step, step_mdp and partial reset (``tests/world`` holds
    them equal) at a fraction of their cost (half the loop at B = 10, measured with
    ``benchmarks/bench_train.py``). Anything else takes TorchRL's path."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # what the fast step reads once: see _fast_path and _added_keys (a plain dict, which
        # nn.Module stores as is; emptied when a transform is added)
        self._shortcuts: dict[str, Any] = {}

    def _forget_shortcuts(self) -> None:
        shortcuts = vars(self).get("_shortcuts")  # absent while ``__init__`` runs
        if shortcuts:
            shortcuts.clear()

    def step_and_maybe_reset(
        self, tensordict: TensorDictBase
    ) -> tuple[TensorDictBase, TensorDictBase]:
        base, transform, batch, added = self._fast_path()
        root = tensordict_items(tensordict, batch)
        if (
            not isinstance(base, BatchedWorldEnv)
            or root is None
            or "next" in root
            or "_step" in root
            or added is None
        ):
            return super().step_and_maybe_reset(tensordict)
        tensordict, following = base.step_and_reset_entries(tensordict, root)
        nxt = transform_step(transform, tensordict, read(tensordict, "next"))
        write(tensordict, {"next": nxt})
        write(following, {key: read(nxt, key) for key in added})
        done = read(nxt, "done")
        if done.numpy().any():
            marked = new_tensordict({"_reset": done}, batch)
            following = transform_reset(transform, marked, following)
        return tensordict, following

    def _fast_path(self) -> tuple[Any, Any, torch.Size, list[str] | None]:
        """The base env, the transform, the batch size and :meth:`_added_keys`, kept after the
        first call (read through TorchRL's properties and ``nn.Module`` lookups, they cost
        about as much as the rest of the step's glue)."""
        known = self._shortcuts.get("fast")
        if known is None:
            known = (self.base_env, self.transform, self.batch_size, self._added_keys())
            self._shortcuts["fast"] = known
        return known

    def append_transform(self, transform: Any) -> BatchedTransformedEnv:
        self._forget_shortcuts()  # the keys are read again
        return super().append_transform(transform)

    def insert_transform(self, index: int, transform: Any) -> BatchedTransformedEnv:
        self._forget_shortcuts()
        return super().insert_transform(index, transform)

    def _added_keys(self) -> list[str] | None:
        """The observation keys the transforms add (None if one is nested: TorchRL's path
        then), read from the specs once (walking them costs more than a step's physics)."""
        known = self._shortcuts.get("added")
        if known is None:
            base_keys = set(self.base_env.observation_spec.keys())
            added = [
                key
                for key in self.observation_spec.keys()  # noqa: SIM118 - a spec
                if key not in base_keys
            ]
            known = (None if any(type(key) is not str for key in added) else added,)
            self._shortcuts["added"] = known
        return known[0]
