"""One growing RBF network (a TESEO "expert", paper sections 7.1 and 8.1).

Each neuron j holds a centre c_j (the input it encodes), a prototypical action p_j, a utility
u_j and an exploration mean mu_j. Storage is preallocated (``capacity`` rows) with an active
count, so adding a neuron is a row write, not a reallocation; when full, storage doubles (an
amortised O(1) growth) up to ``max_neurons``, past which :meth:`add` raises. The sizes are
buffers too, and :meth:`_load_from_state_dict` resizes storage first, so a grown expert's
``state_dict`` loads into a freshly built one.

Scalar rows (actions, utilities, means, taken, used) are also exposed as numpy views of the same
memory (``expert.rows.utilities[i]``): reading or writing one element costs ~0.1 us there
against ~2-3 us through a torch tensor, and the per-step update touches a dozen of them.

Everything is updated in place under ``torch.no_grad()``: growth replaces rows, which an
optimizer could not track (research/TORCHRL.md, "Updates without gradients").
"""

from __future__ import annotations

from types import SimpleNamespace

import torch
from torch import nn

__all__ = ["GrowingRBFExpert"]

# Per-neuron rows; every one is resized together when storage doubles.
_ROWS = ("centres", "sqnorms", "actions", "utilities", "means", "taken", "used")


class GrowingRBFExpert(nn.Module):
    """A growing RBF network with fixed receptive width and a winner-take-all readout."""

    centres: torch.Tensor
    sqnorms: torch.Tensor
    actions: torch.Tensor
    utilities: torch.Tensor
    means: torch.Tensor
    taken: torch.Tensor
    used: torch.Tensor
    count: torch.Tensor

    def __init__(
        self,
        dim: int = 32,
        width: float = 0.1,
        novelty_radius: float = 0.1,
        capacity: int = 1024,
        max_neurons: int = 200_000,
        name: str = "expert",
    ) -> None:
        super().__init__()
        if dim < 1 or capacity < 1:
            raise ValueError(f"GrowingRBFExpert: dim={dim} and capacity={capacity} must be >= 1")
        self.dim = dim
        self.width = float(width)
        self.novelty_radius = float(novelty_radius)
        self.max_neurons = int(max_neurons)
        self.name = name
        self.register_buffer("centres", torch.zeros(capacity, dim))
        # ||c_j||^2, kept in step with the centres: the winner search is then one matrix-vector
        # product (d^2 = ||c||^2 - 2 c.x + ||x||^2), ~4x cheaper than differences at 500 neurons.
        self.register_buffer("sqnorms", torch.zeros(capacity), persistent=False)
        self.register_buffer("actions", torch.zeros(capacity))
        self.register_buffer("utilities", torch.zeros(capacity))
        self.register_buffer("means", torch.zeros(capacity))
        # The action each neuron took last in this trial and whether it was used (action
        # replacement at the end of a successful trial, ALGORITHM.md step 8).
        self.register_buffer("taken", torch.zeros(capacity))
        self.register_buffer("used", torch.zeros(capacity, dtype=torch.bool))
        self.register_buffer("count", torch.zeros((), dtype=torch.long))
        self._n = 0  # python mirror of `count`: no tensor sync on the hot path
        self._refresh_views()

    def _refresh_views(self) -> None:
        """Numpy views sharing memory with the scalar rows (rebuilt whenever storage moves)."""
        self.rows = SimpleNamespace(
            **{name: getattr(self, name).numpy() for name in _ROWS if name != "centres"}
        )
        self._active: tuple[int, torch.Tensor, torch.Tensor] | None = None  # nearest()'s views

    def _apply(self, fn, recurse=True):  # .to() / .float() etc. replace the buffers
        out = super()._apply(fn, recurse)
        if self.centres.device.type == "cpu":
            self._refresh_views()
        return out

    # -- size -----------------------------------------------------------------------------
    def __len__(self) -> int:
        return self._n

    @property
    def capacity(self) -> int:
        return self.centres.shape[0]

    def _resize(self, capacity: int) -> None:
        for name in _ROWS:
            old = getattr(self, name)
            new = old.new_zeros((capacity, *old.shape[1:]))
            keep = min(capacity, old.shape[0])
            new[:keep] = old[:keep]
            setattr(self, name, new)  # nn.Module keeps it registered as a buffer
        self._refresh_views()

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):  # type: ignore[override]
        """Resize storage to the saved size first, so a grown expert loads into a new one."""
        saved = state_dict.get(prefix + "centres")
        if saved is not None and saved.shape[0] != self.capacity:
            self._resize(saved.shape[0])
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)
        self._n = int(self.count)
        self.sqnorms.copy_(self.centres.square().sum(-1))
        self._refresh_views()

    # -- competition ----------------------------------------------------------------------
    def nearest(self, x: torch.Tensor) -> tuple[int, float]:
        """Index of the winner (argmax activation = argmin distance) and its distance; (-1, inf)
        when the expert is empty."""
        n = self._n
        if n == 0:
            return -1, float("inf")
        active = self._active  # the [:n] views, made once per size instead of every call
        if active is None or active[0] != n:
            active = (n, self.sqnorms[:n], self.centres[:n])
            self.__dict__["_active"] = active  # plain attribute: skips Module.__setattr__
        # argmin_j ||x - c_j||^2 = argmin_j (||c_j||^2 - 2 c_j.x): one fused addmv.
        i = int(torch.addmv(active[1], active[2], x, alpha=-2.0).argmin())
        return i, float(torch.dist(active[2][i], x))

    def is_novel(self, distance: float) -> bool:
        """Distance-driven growth test (paper 8.1): nothing within the novelty radius."""
        return distance > self.novelty_radius

    def activations(self, x: torch.Tensor) -> torch.Tensor:
        """phi_j(x) = exp(-||x - c_j||^2 / width^2) over the active neurons (for plots/critics)."""
        d2 = (self.centres[: self._n] - x).square().sum(-1)
        return torch.exp(-d2 / self.width**2)

    # -- growth ---------------------------------------------------------------------------
    @torch.no_grad()
    def add(self, centre: torch.Tensor, action: float, utility: float, mean: float = 0.0) -> int:
        """Append a neuron and return its index; doubles storage when full."""
        n = self._n
        if n >= self.capacity:
            if n >= self.max_neurons:
                raise RuntimeError(
                    f"expert {self.name!r} reached learner.max_neurons={self.max_neurons}; "
                    "raise it or the novelty radius"
                )
            self._resize(min(2 * self.capacity, self.max_neurons))
        self.centres[n] = centre
        rows = self.rows
        rows.sqnorms[n] = float(centre.square().sum())
        rows.actions[n] = action
        rows.utilities[n] = utility
        rows.means[n] = mean
        rows.taken[n] = 0.0
        rows.used[n] = False
        self.__dict__["_n"] = n + 1  # plain attribute: skips Module.__setattr__ (~3 us)
        self.count.fill_(n + 1)
        return n

    @torch.no_grad()
    def shift_centre(self, i: int, target: torch.Tensor, rate: float) -> None:
        """c_i += rate * (target - c_i), keeping the cached squared norm in step."""
        c = self.centres[i]
        c.lerp_(target, rate)
        self.rows.sqnorms[i] = float(c.square().sum())

    # -- end of trial ---------------------------------------------------------------------
    @torch.no_grad()
    def replace_actions(self) -> int:
        """p <- the action taken, mu <- 0, for every neuron used this trial; returns how many."""
        used = self.used[: self._n]
        self.actions[: self._n] = torch.where(used, self.taken[: self._n], self.actions[: self._n])
        self.means[: self._n].masked_fill_(used, 0.0)
        return int(used.sum())

    @torch.no_grad()
    def clear_trial(self) -> None:
        """Forget which neurons were used (start of a new trial)."""
        self.used.zero_()

    def extra_repr(self) -> str:
        return (
            f"name={self.name!r}, neurons={self._n}, capacity={self.capacity}, dim={self.dim}, "
            f"width={self.width}, novelty_radius={self.novelty_radius}"
        )
