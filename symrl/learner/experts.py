"""Growing RBF networks (TESEO's "experts", paper sections 7.1 and 8.1) for B controllers at once.

One :class:`ExpertBank` holds, for each of B independent controllers (one per robot of a batch)
and each of E experts (one per map region), a growing set of neurons: a centre c_j (the input it
encodes), a prototypical action p_j, a utility u_j and an exploration mean mu_j. Storage is padded
to a common capacity N with a neuron count per (controller, expert); when any of them is full,
storage doubles for all (amortised O(1) growth) up to ``max_neurons``.

Every query and write is vectorised over the batch (no Python loop over controllers), and each
controller's results depend only on its own rows: the same controller gives the same numbers
whatever the batch it sits in (tests pin this).

The bank holds parameters only; the policy reads them (winner search), the update writes them
(growth, TD, REINFORCE, centre shift, action replacement), always in place under ``no_grad``:
growth replaces rows, which an optimizer could not follow.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.grad import no_grad

__all__ = ["ExpertBank", "expert_names"]

# Per-neuron tensors (B, E, N[, D]); every one is resized together when storage doubles.
_ROWS = ("centres", "actions", "utilities", "means", "taken", "used")


def expert_names(config: Any, world: Any) -> tuple[str, ...]:
    """The experts of a controller of ``config`` in ``world``: one per map region, or one for
    all (``"all"``) without the partition."""
    return tuple(world.regions.names) if config.gate.partition else ("all",)


def _sum_last(squares: np.ndarray) -> np.ndarray:
    """torch's sum over the last axis of float32 squares (the winner search's distances), as a
    new array. Four terms (the pose input) are added in numpy in torch's order,
    ((a + b) + c) + d, the same numbers (``tests/learner/test_experts.py`` pins it): a torch
    reduction costs several numpy calls inside the control loop. Other lengths stay torch's
    (its reduction order for them is not a plain left-to-right one)."""
    if squares.shape[-1] == 4 and squares.dtype == np.float32:
        return ((squares[..., 0] + squares[..., 1]) + squares[..., 2]) + squares[..., 3]
    return torch.from_numpy(squares).sum(-1).numpy()


class FlatViews(NamedTuple):
    """Numpy views of an :class:`ExpertBank`'s storage, one row per (controller, expert,
    neuron) slot: index them with :meth:`ExpertBank.flat_index_np`."""

    centres: np.ndarray
    """(B * E * N, D)"""
    actions: np.ndarray
    """(B * E * N,), as are ``utilities``, ``means``, ``taken`` and ``used``."""
    utilities: np.ndarray
    means: np.ndarray
    taken: np.ndarray
    used: np.ndarray
    counts: np.ndarray
    """(B * E,) neurons per (controller, expert)."""
    row_base: np.ndarray
    """(B,) b * E."""
    arange: np.ndarray
    """(N,) 0 .. N - 1."""
    capacity: int
    """N."""
    banks: np.ndarray
    """(B * E, N, D) ``centres``, one row of neurons per (controller, expert)."""


class ExpertBank(BufferViews):
    """B controllers x E experts of growing RBF neurons in padded tensors."""

    centres: torch.Tensor
    actions: torch.Tensor
    utilities: torch.Tensor
    means: torch.Tensor
    taken: torch.Tensor
    used: torch.Tensor
    count: torch.Tensor

    def __init__(
        self,
        batch: int,
        experts: int,
        dim: int,
        capacity: int = 64,
        max_neurons: int = 100_000,
        names: tuple[str, ...] | None = None,
    ) -> None:
        super().__init__()
        if min(batch, experts, dim, capacity) < 1:
            raise ValueError(
                f"ExpertBank: batch={batch}, experts={experts}, dim={dim}, capacity={capacity} "
                "must all be >= 1"
            )
        self.dim = dim
        self.max_neurons = int(max_neurons)
        self.names = names or tuple(f"expert{e}" for e in range(experts))
        shape = (batch, experts, capacity)
        self.register_buffer("centres", torch.zeros(*shape, dim))
        self.register_buffer("actions", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("utilities", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("means", torch.zeros(shape, dtype=torch.float64))
        # the action each neuron took last in this trial, and whether it was used: action
        # replacement at the end of a better successful trial (paper 8.3)
        self.register_buffer("taken", torch.zeros(shape, dtype=torch.float64))
        self.register_buffer("used", torch.zeros(shape, dtype=torch.bool))
        self.register_buffer("count", torch.zeros(batch, experts, dtype=torch.long))
        # b * E: the first (controller, expert) row of controller b in the flattened storage
        self._row_base = torch.arange(batch) * experts
        self._arange = torch.arange(capacity)

    # -- sizes ----------------------------------------------------------------------------
    @property
    def batch(self) -> int:
        return self.centres.shape[0]

    @property
    def capacity(self) -> int:
        return self.centres.shape[2]

    def _resize(self, capacity: int) -> None:
        for name in _ROWS:
            old = getattr(self, name)
            new = old.new_zeros((*old.shape[:2], capacity, *old.shape[3:]))
            keep = min(capacity, old.shape[2])
            new[:, :, :keep] = old[:, :, :keep]
            setattr(self, name, new)  # nn.Module keeps it registered as a buffer
        self._arange = torch.arange(capacity)

    @property
    def flat(self) -> FlatViews:
        """Numpy views of the storage for the control loop's arithmetic (a ``.numpy()`` call
        costs about a microsecond and the loop asks ~40 times a step). Cached until a buffer
        is replaced: growth beyond the capacity, ``.to()``, loading with ``assign``."""
        views = self._views.get("flat")  # dropped with the buffers' arrays
        if views is None:
            views = FlatViews(
                centres=self.centres.numpy().reshape(-1, self.dim),
                actions=self.actions.numpy().reshape(-1),
                utilities=self.utilities.numpy().reshape(-1),
                means=self.means.numpy().reshape(-1),
                taken=self.taken.numpy().reshape(-1),
                used=self.used.numpy().reshape(-1),
                counts=self.count.numpy().reshape(-1),
                row_base=self._row_base.numpy(),
                arange=self._arange.numpy(),
                capacity=self.capacity,
                banks=self.centres.numpy().reshape(-1, self.capacity, self.dim),
            )
            self._views["flat"] = views
        return views

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):  # type: ignore[override]
        """Resize storage to the saved size first, so a grown bank loads into a fresh one."""
        saved = state_dict.get(prefix + "centres")
        if saved is not None and saved.shape[2] != self.capacity:
            self._resize(saved.shape[2])
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    # -- competition ----------------------------------------------------------------------
    def flat_index(self, expert: torch.Tensor, neuron: torch.Tensor) -> torch.Tensor:
        """Index of neuron ``neuron[b]`` of expert ``expert[b]`` of every controller b in the
        flattened per-neuron tensors (``bank.utilities.view(-1)[index]``): one gather or
        scatter instead of an advanced index over three dimensions."""
        return (self._row_base + expert) * self.capacity + neuron

    def flat_index_np(self, expert: np.ndarray, neuron: np.ndarray) -> np.ndarray:
        """:meth:`flat_index` on numpy arrays (for arithmetic on ``tensor.numpy()`` views)."""
        flat = self.flat
        return (flat.row_base + expert) * flat.capacity + neuron

    def nearest(self, expert: torch.Tensor, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Winner (argmin distance = argmax activation) in each controller's ``expert`` for its
        input ``x`` (B, D), and the distance; (-1, inf) where that expert is empty.

        In numpy on the tensors' memory (a fraction of the cost of ~20 torch dispatches for a
        handful of rows); the differences and squares are exact in either, and the sum over D
        is torch's reduction (or its order, :func:`_sum_last`), so the distances are those of
        the torch version bit for bit."""
        if int(self.flat.counts[self.flat.row_base + expert.numpy()].max()) == 0:
            return torch.full_like(expert, -1), torch.full((self.batch,), torch.inf)
        winner, distance = self.nearest_np(expert.numpy(), x.numpy())
        return torch.from_numpy(winner), torch.from_numpy(distance)

    def nearest_np(self, expert: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`nearest` on numpy arrays (the control loop's call: no tensors in between)."""
        flat = self.flat
        row = flat.row_base + expert
        counts = flat.counts[row]
        n = int(counts.max())
        if n == 0:
            return np.full(len(row), -1, dtype=np.int64), np.full(len(row), np.inf)
        centres = flat.banks[row, :n]
        d2 = _sum_last(np.square(centres - x[:, None, :]))
        d2[flat.arange[:n] >= counts[:, None]] = np.inf
        winner = d2.argmin(axis=-1)  # the first of equal distances, as torch's min
        distance = np.sqrt(d2[np.arange(len(row)), winner])
        winner[counts == 0] = -1
        return winner, distance

    # -- growth ---------------------------------------------------------------------------
    @no_grad
    def add(
        self,
        rows: torch.Tensor,
        expert: torch.Tensor,
        centre: torch.Tensor,
        action: torch.Tensor,
        utility: torch.Tensor,
    ) -> torch.Tensor:
        """Append one neuron to ``expert[i]`` of controller ``rows[i]`` (rows distinct); returns
        the new neurons' indices. Storage doubles when any expert is full. (Numpy writes on the
        storage's flat views: a handful of rows, a fraction of the torch dispatches; copies
        and casts only, so the same numbers.)"""
        return torch.from_numpy(
            self.add_np(
                rows.numpy(),
                expert.numpy(),
                centre.detach().numpy(),
                action.detach().numpy(),
                utility.detach().numpy(),
            )
        )

    def add_np(
        self,
        rows: np.ndarray,
        expert: np.ndarray,
        centre: np.ndarray,
        action: np.ndarray,
        utility: np.ndarray,
    ) -> np.ndarray:
        """:meth:`add` on numpy arrays (the update's rows are numpy already: no small-tensor
        indexing in between)."""
        flat = self.flat
        row = flat.row_base[rows] + expert  # (controller, expert) rows
        index = flat.counts[row]
        if len(index) == 0:
            return index
        top = int(index.max())
        if top >= self.capacity:
            if top >= self.max_neurons:
                name = self.names[int(expert[int(index.argmax())])]
                raise RuntimeError(
                    f"expert {name!r} reached experts.max_neurons={self.max_neurons}; "
                    "raise it or the novelty radius"
                )
            self._resize(min(2 * self.capacity, self.max_neurons))
            flat = self.flat
        slot = row * flat.capacity + index
        flat.centres[slot] = centre
        flat.actions[slot] = action
        flat.utilities[slot] = utility
        flat.means[slot] = 0.0
        flat.taken[slot] = 0.0
        flat.used[slot] = False
        flat.counts[row] = index + 1
        return index

    # -- the update's steps ---------------------------------------------------------------
    def mark_taken(self, index: np.ndarray, taken: np.ndarray) -> None:
        """The neurons at flat ``index`` (:meth:`flat_index_np`) took actions ``taken``
        (relative to their base): remembered for action replacement at the trial's end."""
        flat = self.flat
        flat.taken[index] = taken
        flat.used[index] = True

    def learn(
        self,
        index: np.ndarray,
        utility: np.ndarray,
        step: np.ndarray,
        xi: np.ndarray,
        x: np.ndarray,
        shift: np.ndarray,
        rates: tuple[float, float, float],
    ) -> None:
        """The TD(0) and REINFORCE steps of the neurons at flat ``index``, whose utility was
        ``utility``, by the TD errors ``step`` (0 where a row does not learn) and the
        exploration draws ``xi``; the neurons where ``shift`` move their centre toward their
        input ``x``. ``rates``: (eta, beta, kappa). Numpy on the storage (a handful of rows),
        the centre shift a torch ``lerp``."""
        eta, beta, kappa = rates
        flat = self.flat
        flat.utilities[index] = utility + eta * step
        means = flat.means
        mu = means[index]
        means[index] = mu + beta * step * (xi - mu)
        if shift.any():  # the gathers and the scatter in numpy, the lerp torch's
            a = np.flatnonzero(shift)
            slots = index[a]
            centres = flat.centres
            moved = torch.from_numpy(centres[slots])
            moved.lerp_(torch.from_numpy(x[a]), kappa)
            centres[slots] = moved.numpy()

    def step_means(self, index: np.ndarray, step: np.ndarray, limit: float) -> None:
        """mu += ``step`` at the flat ``index`` (distinct), kept within +-``limit``."""
        means = self.flat.means
        means[index] = np.minimum(np.maximum(means[index] + step, -limit), limit)

    # -- end of trial ---------------------------------------------------------------------
    @no_grad
    def replace_actions(self, rows: torch.Tensor) -> torch.Tensor:
        """p <- the action taken, mu <- 0, for every neuron used this trial by controllers
        ``rows``; returns how many per row."""
        r = rows.numpy()
        used = self.used.numpy()[r]
        actions, means = self.actions.numpy(), self.means.numpy()
        actions[r] = np.where(used, self.taken.numpy()[r], actions[r])
        means[r] = np.where(used, 0.0, means[r])
        return torch.from_numpy(used.reshape(len(r), -1).sum(-1))

    @no_grad
    def clear_trial(self, rows: torch.Tensor) -> None:
        """Forget which neurons controllers ``rows`` used (a new trial starts)."""
        self.used.numpy()[rows.numpy()] = False

    def neurons(self) -> torch.Tensor:
        """Neurons per controller and expert, (B, E)."""
        return self.count.clone()

    def extra_repr(self) -> str:
        return (
            f"batch={self.batch}, experts={self.names}, dim={self.dim}, "
            f"capacity={self.capacity}, neurons={self.count.sum(-1).tolist()}"
        )
