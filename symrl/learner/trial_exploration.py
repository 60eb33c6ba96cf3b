"""Exploration held constant over a trial (parameter-space exploration of the experts).

Why this exists (docs/LEARNING.md, "Exploration held constant over a trial"): the paper's
actor draws a new exploration value xi at every step and learns from the one-step TD error.
The reflex is a feedback controller, so whatever one step does the next reflex action steers
back; a one-step draw correlates with the return-to-go by at most 0.06 and REINFORCE sees
noise. Here every neuron instead gets one perturbation ``kick`` for the whole trial, drawn
when the trial starts, so a consistent change of the correction is tried wherever the neuron
wins and its whole effect is in the trial's return. At the end of the trial each neuron that
acted with its kick moves its exploration mean toward the kick when the return-to-go from its
region's first entry beat the region's option critic (the mean return-to-go of the option
chosen there), and away from it when it lost (a PGPE / finite-difference step):

    mu_i += rate * clip(G_region - q_option, -clip, clip) * kick_i      for used neurons i

Kicks are drawn N(0, sigma_t^2), sigma_t = sigma * decay^t in trial t (counted from 0), from
a stream seeded by the robot's seed and the trial number, so they do not depend on the batch,
on the order the neurons were met or on a resumed run's saved random state.

The policy owns a :class:`TrialPerturbation` and reads a neuron's kick when it acts (it writes
the kick into the TensorDict); the update marks the neurons that acted with a kick
(:meth:`mark`) and takes the step at the trial's end (:meth:`learn`); the policy redraws at
the next trial's start (:meth:`begin_trial`).

:class:`SubgoalSearch` applies the same rule to the sub-goal options' points: each option has a
learned offset, each region's point is moved by one jitter per trial, and the offset of the
option chosen in a region steps toward the jitter when the region's return-to-go beat the
option's critic (learned continuous sub-goal positions).
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["SubgoalSearch", "TrialPerturbation", "option_advantage", "trial_normal"]

_BLOCK = 64  # neuron slots drawn per (robot, expert) stream; storage grows by whole blocks
_SALT = 104_729  # separates the kicks' streams from the exploration's and the options'
_SEARCH_SALT = 1_299_709  # the sub-goal jitters' streams


def trial_normal(seed: int, trial: int, salt: int, shape: tuple[int, ...]) -> torch.Tensor:
    """Standard normals for robot ``seed`` in trial ``trial`` (a stream per ``salt``): the same
    numbers whatever the batch, the order of calls or a resumed run's saved random state."""
    key = ((seed * 1_000_003 + trial) * 7_919 + salt) % (2**63)
    return torch.randn(shape, generator=torch.Generator().manual_seed(key), dtype=torch.float64)


class TrialPerturbation(nn.Module):
    """Per-trial kicks of B robots' E experts; ``kick`` and ``applied`` are (B, E, N) like the
    expert bank's per-neuron storage, so the bank's flat neuron index addresses them."""

    kick: torch.Tensor
    applied: torch.Tensor
    trial: torch.Tensor

    def __init__(self, seeds: list[int], experts: int, config: object) -> None:
        super().__init__()
        self.seeds = [int(s) for s in seeds]
        self.experts = int(experts)
        self.config = config
        batch = len(self.seeds)
        # the kicks are derived from (seed, trial): only the trial is saved, and a loaded
        # controller draws its trial's kicks again (a resumed run acts as the uninterrupted one)
        self.register_buffer("kick", torch.zeros(batch, experts, 0, dtype=torch.float64),
                             persistent=False)  # fmt: skip
        self.register_buffer("applied", torch.zeros(batch, experts, 0, dtype=torch.bool),
                             persistent=False)  # fmt: skip
        self.register_buffer("trial", torch.zeros(batch, dtype=torch.long))

    def _load_from_state_dict(self, *args, **kwargs):  # type: ignore[override]
        super()._load_from_state_dict(*args, **kwargs)
        self.kick = self.kick[:, :, :0].clone()  # redrawn for the loaded trials when next read
        self.applied = self.applied[:, :, :0].clone()

    @property
    def capacity(self) -> int:
        return self.kick.shape[2]

    def sigma(self, trial: int) -> float:
        """The kicks' scale in trial ``trial`` (0-based)."""
        return float(self.config.sigma) * float(self.config.decay) ** trial  # type: ignore[attr-defined]

    def _block(self, b: int, block: int) -> torch.Tensor:
        """Robot ``b``'s kicks (E, _BLOCK) for neuron slots ``block * _BLOCK ...`` this trial."""
        trial = int(self.trial[b])
        draw = trial_normal(self.seeds[b], trial, _SALT + block, (self.experts, _BLOCK))
        return draw * self.sigma(trial)

    def fit(self, capacity: int) -> None:
        """Grow the storage (whole blocks, drawn for the current trials) to hold ``capacity``
        neuron slots per expert; the expert bank calls for the same when it doubles."""
        if capacity <= self.capacity:
            return
        old = self.capacity
        blocks = -(-capacity // _BLOCK)
        kick = self.kick.new_zeros((*self.kick.shape[:2], blocks * _BLOCK))
        kick[:, :, :old] = self.kick
        for b in range(len(self.seeds)):
            for k in range(old // _BLOCK, blocks):
                kick[b, :, k * _BLOCK : (k + 1) * _BLOCK] = self._block(b, k)
        applied = self.applied.new_zeros(kick.shape)
        applied[:, :, :old] = self.applied
        self.kick, self.applied = kick, applied

    def flat(self, expert: torch.Tensor, neuron: torch.Tensor) -> torch.Tensor:
        """The flat index of neuron ``neuron[b]`` of expert ``expert[b]`` of every robot b."""
        base = torch.arange(len(self.seeds)) * self.experts
        return (base + expert) * self.capacity + neuron

    # -- acting (the policy) ------------------------------------------------------------
    def at(self, expert: torch.Tensor, neuron: torch.Tensor, capacity: int) -> torch.Tensor:
        """The kick (B,) of each robot's neuron ``neuron`` of ``expert`` in this trial."""
        self.fit(capacity)
        return self.kick.view(-1).take(self.flat(expert, neuron))

    @torch.no_grad()
    def begin_trial(self, rows: torch.Tensor, trials: torch.Tensor) -> None:
        """Robots ``rows`` start their trial ``trials`` (0-based, (k,)): new kicks."""
        self.trial[rows] = trials
        for b in rows.tolist():
            for k in range(self.capacity // _BLOCK):
                self.kick[b, :, k * _BLOCK : (k + 1) * _BLOCK] = self._block(b, k)
        self.applied[rows] = False

    # -- learning (the update) ----------------------------------------------------------
    @torch.no_grad()
    def mark(self, expert: torch.Tensor, neuron: torch.Tensor, acted: torch.Tensor,
             capacity: int) -> None:  # fmt: skip
        """The robots where ``acted`` acted with the kick of ``neuron`` of ``expert``."""
        self.fit(capacity)
        index = self.flat(expert, neuron)[acted]
        self.applied.view(-1).index_fill_(0, index, True)

    @torch.no_grad()
    def learn(self, rows: torch.Tensor, advantage: torch.Tensor, means: torch.Tensor) -> None:
        """End of the trials of ``rows``: ``advantage`` (k, E) is each expert's return-to-go
        minus its baseline (0 where none); every neuron that acted with its kick moves its
        exploration mean in ``means`` (B, E, N, written in place) by rate * advantage * kick."""
        cfg = self.config
        n = means.shape[2]
        self.fit(n)
        a = advantage.to(torch.float64).clamp(-cfg.clip, cfg.clip)  # type: ignore[attr-defined]
        step = cfg.rate * a[:, :, None] * self.kick[rows, :, :n]  # type: ignore[attr-defined]
        means[rows] += step * self.applied[rows, :, :n]


def option_advantage(options: object, rows: torch.Tensor, returns: torch.Tensor) -> torch.Tensor:
    """(k, R) return-to-go from each region's first entry (``returns``) minus the mean
    return-to-go of the option chosen there (the option critic before this trial); 0 for a
    region not entered or an option never finished before (no baseline yet)."""
    choice = options.choice[rows]  # type: ignore[attr-defined]
    pick = choice.clamp(min=0)[:, :, None]
    q = options.q[rows].gather(2, pick).squeeze(2)  # type: ignore[attr-defined]
    n = options.n[rows].gather(2, pick).squeeze(2)  # type: ignore[attr-defined]
    known = (choice >= 0) & (n > 0)
    return torch.where(known, returns - q, torch.zeros_like(returns))


class SubgoalSearch(nn.Module):
    """Learned offsets of B robots' sub-goal points, explored by one jitter per region and trial.

    Buffers: ``offset`` (B, R, K, 2) learned per option, ``jitter`` (B, R, 2) this trial's move
    of each region's point (drawn from the seed and the trial; saved, so a resumed run that
    starts inside a trial moves its points as the uninterrupted run did).
    """

    offset: torch.Tensor
    jitter: torch.Tensor

    def __init__(self, seeds: list[int], regions: int, options: int, config: object) -> None:
        super().__init__()
        self.seeds = [int(s) for s in seeds]
        self.config = config
        batch = len(self.seeds)
        self.register_buffer("offset", torch.zeros(batch, regions, options, 2, dtype=torch.float64))
        self.register_buffer("jitter", torch.zeros(batch, regions, 2, dtype=torch.float64))
        self.begin_trial(torch.arange(batch), torch.zeros(batch, dtype=torch.long))

    def sigma(self, trial: int) -> float:
        """The jitters' scale in trial ``trial`` (0-based), metres."""
        return float(self.config.sigma) * float(self.config.decay) ** trial  # type: ignore[attr-defined]

    @torch.no_grad()
    def begin_trial(self, rows: torch.Tensor, trials: torch.Tensor) -> None:
        """Robots ``rows`` start their trial ``trials`` (0-based): new jitters."""
        for b, t in zip(rows.tolist(), trials.tolist(), strict=True):
            draw = trial_normal(self.seeds[b], t, _SEARCH_SALT, tuple(self.jitter.shape[1:]))
            self.jitter[b] = draw * self.sigma(t)

    def shift(self, region: torch.Tensor, option: torch.Tensor, greedy: bool) -> torch.Tensor:
        """(B, 2) how far each robot's point of ``option`` in ``region`` is moved now (the
        learned offset, plus this trial's jitter unless greedy)."""
        rows = torch.arange(len(self.seeds))
        move = self.offset[rows, region, option]
        return move if greedy else move + self.jitter[rows, region]

    @torch.no_grad()
    def learn(self, rows: torch.Tensor, advantage: torch.Tensor, choice: torch.Tensor) -> None:
        """End of the trials of ``rows``: the offset of the option ``choice`` (k, R; -1: region
        not entered) steps by rate * clip(advantage) * jitter, kept within ``max_shift``."""
        cfg = self.config
        a = advantage.clamp(-cfg.clip, cfg.clip)  # type: ignore[attr-defined]
        entered = choice >= 0
        b = rows[:, None].expand_as(choice)[entered]
        r = torch.arange(choice.shape[1]).expand_as(choice)[entered]
        k = choice[entered]
        step = cfg.rate * a[entered][:, None] * self.jitter[b, r]  # type: ignore[attr-defined]
        moved = self.offset[b, r, k] + step
        norm = torch.linalg.vector_norm(moved, dim=-1, keepdim=True)
        limit = float(cfg.max_shift)  # type: ignore[attr-defined]
        self.offset[b, r, k] = moved * (limit / norm.clamp(min=limit))
