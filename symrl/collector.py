"""The training loop's data collector: one batched env step of B robots per batch.

``StepCollector`` is a TorchRL collector (a ``torchrl.collectors.BaseCollector``, the base of
TorchRL's own ``Collector``, named ``DataCollectorBase`` in earlier TorchRL releases) with the
iteration protocol of TorchRL's: ``for batch in collector: loss(batch)``, ``state_dict`` /
``load_state_dict``, ``update_policy_weights_``, ``set_seed``, ``shutdown``. Each batch is one
step of the B robots of a batched env (batch size [B], the transitions with their ``"next"``),
taken with the env's ``step_and_maybe_reset``: the robots whose trial ended are restarted (a
partial reset) before the next batch, whose policy call sees their new trial's first state.

Why not TorchRL's ``Collector`` itself: with ``frames_per_batch = B`` it gives the same trials
(``use_buffers=False``: with its preallocated buffers it runs the policy once on a spec-shaped
TensorDict to size them, which draws exploration noise and changes every trial after), but
every batch it stacks the step into a [B, 1] TensorDict, walks its keys to drop the private
ones and (unless ``return_same_td``) clones it: an online update that consumes each
transition once needs none of it. Measured with ``benchmarks/bench_train.py --rounds 3``
(recipe paper, robot-steps per CPU second as a fraction of the raw Gymnasium env's, best of 3
interleaved rounds on the shared 2-core VM), with TorchRL's ``Collector`` at its cheapest
documented options that keep the trials (``use_buffers=False``, ``return_same_td=True``,
``device="cpu"``, ``track_traj_ids=False``, ``trust_policy=True``):

| B | bare loop | TorchRL Collector | StepCollector |
| ---: | ---: | ---: | ---: |
| 1 | 0.09 | 0.05 | 0.09 |
| 10 | 0.52 | 0.35 | 0.52 |
| 100 | 1.68 | 1.44 | 1.69 |

At B = 10, the size of a study, TorchRL's ``Collector`` holds the loop to two thirds of its
speed, under the 0.5 the training loop is held to; this collector costs a Python generator
step and an exploration-type context per batch.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Iterator
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.collectors import BaseCollector
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

__all__ = ["StepCollector"]


class StepCollector(BaseCollector):
    """Batches of one env step of every robot of ``env`` (batch size [B]) acted by ``policy``.

    ``total_frames``: robot-steps to collect (B per batch; -1: until the loop stops).
    ``exploration_type``: TorchRL's, set around each policy call (RANDOM: the policy draws its
    exploration noise). The env is reset when the first batch is asked for (TorchRL's collectors
    reset it when they are built), unless :meth:`load_state_dict` put it, and the TensorDict
    the next batch starts from, where a :meth:`state_dict` left them: nothing is drawn from
    the env's random streams before a resumed run's state is loaded.
    """

    def __init__(
        self,
        env: EnvBase,
        policy: Any,
        *,
        total_frames: int = -1,
        exploration_type: ExplorationType = ExplorationType.RANDOM,
    ) -> None:
        super().__init__()
        if len(env.batch_size) != 1:
            raise ValueError(
                f"StepCollector: the env needs a batch size [B], got {list(env.batch_size)}"
            )
        self.env = env
        self.policy = policy
        self.exploration_type = exploration_type
        self.trajs_per_batch = None  # BaseCollector's iteration: fixed-frame batches
        self.frames_per_batch = env.batch_size.numel()
        self.requested_frames_per_batch = self.frames_per_batch
        self.total_frames = float("inf") if total_frames < 0 else int(total_frames)
        self.closed = False
        self._frames = 0
        self._iter = -1
        self._carrier: TensorDictBase | None = None

    def iterator(self) -> Iterator[TensorDictBase]:
        """Yield one batch per env step: the transitions of every robot, with ``"next"``."""
        env, policy, exploration = self.env, self.policy, self.exploration_type
        batch = self.frames_per_batch
        td = self._carrier if self._carrier is not None else env.reset()
        while self._frames < self.total_frames:
            self._iter += 1
            with set_exploration_type(exploration):
                policy(td)
            transitions, td = env.step_and_maybe_reset(td)
            self._carrier = td
            self._frames += batch
            yield transitions

    def state_dict(self) -> OrderedDict:
        """The env's run state (``env.run_state()``, for envs that have one), the TensorDict
        the next batch starts from (the robots' current observations and their perception)
        and the frame and batch counters. The policy is saved on its own."""
        if self._carrier is None:
            self._carrier = self.env.reset()
        carrier = self._carrier
        base = getattr(self.env, "base_env", self.env)
        run_state = getattr(base, "run_state", None)
        return OrderedDict(
            env_state_dict=run_state() if run_state is not None else {},
            carrier=carrier.clone().to_dict(),
            frames=self._frames,
            iter=self._iter,
        )

    def load_state_dict(self, state_dict: OrderedDict | dict[str, Any], **kwargs: Any) -> None:
        """Go on from :meth:`state_dict` (the same env, freshly built)."""
        base = getattr(self.env, "base_env", self.env)
        if state_dict["env_state_dict"]:
            base.load_run_state(state_dict["env_state_dict"])
        self._carrier = TensorDict(state_dict["carrier"], batch_size=self.env.batch_size)
        self._frames = int(state_dict["frames"])
        self._iter = int(state_dict["iter"])

    def update_policy_weights_(  # type: ignore[override]
        self, policy_or_weights: Any = None, **kwargs: Any
    ) -> None:
        """The policy is the training loop's own module (the update steps it in place), so
        its weights are current and a call without weights does nothing. Given a module
        (positional or ``policy=``), a state dict or a TensorDict of one (positional or
        ``weights=``), load it into the policy."""
        weights = policy_or_weights
        if weights is None:
            weights = kwargs.get("weights", kwargs.get("policy"))
        if weights is None:
            return
        if isinstance(weights, torch.nn.Module):
            weights = weights.state_dict()
        elif isinstance(weights, TensorDictBase):
            weights = weights.flatten_keys(".").to_dict()
        self.policy.load_state_dict(dict(weights))

    def set_seed(self, seed: int, static_seed: bool = False) -> int:
        """Seed the env (TorchRL's ``env.set_seed``)."""
        return self.env.set_seed(seed, static_seed=static_seed)

    def shutdown(
        self, timeout: float | None = None, close_env: bool = True, raise_on_error: bool = True
    ) -> None:
        """Close the env (once)."""
        if self.closed:
            return
        self.closed = True
        if close_env and not self.env.is_closed:
            self.env.close(raise_if_closed=raise_on_error)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(env={type(self.env).__name__}, "
            f"batch={self.frames_per_batch}, frames={self._frames})"
        )
