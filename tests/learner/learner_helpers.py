"""Hand-made observations and transitions for the learner tests (no env needed)."""

from __future__ import annotations

import torch
from tensordict import TensorDict

from symrl.learner.policy import MixtureOfExpertsPolicy, Observation


def obs(
    sonar: float | list[float] = 0.5,
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    goal: tuple[float, float] = (4.0, 0.0),
) -> Observation:
    """One observation; ``sonar`` a constant or 24 values (normalised)."""
    s = torch.full((24,), float(sonar)) if isinstance(sonar, float) else torch.tensor(sonar)
    return Observation(
        sonar=s.float(),
        ir=torch.zeros(24),
        bumper=torch.zeros(1),
        odometry=torch.tensor(pose, dtype=torch.float32),
        goal=torch.tensor(goal, dtype=torch.float32),
    )


def obs_td(o: Observation) -> TensorDict:
    return TensorDict(dict(o._asdict()), [])


def transition(
    policy: MixtureOfExpertsPolicy,
    now: Observation,
    nxt: Observation,
    reward: float,
    terminated: bool = False,
    truncated: bool = False,
) -> TensorDict:
    """Act on ``now`` with ``policy`` and build the [1]-batched transition a Collector yields."""
    td = policy(obs_td(now))
    td.set("next", obs_td(nxt))
    td.set(("next", "reward"), torch.tensor([reward]))
    td.set(("next", "terminated"), torch.tensor([terminated]))
    td.set(("next", "truncated"), torch.tensor([truncated]))
    td.set(("next", "done"), torch.tensor([terminated or truncated]))
    return td.unsqueeze(0)
