"""A safety shield on the IR ring: the third piece of hand-made prior knowledge.

The paper uses the IR sensors "solely in emergency conditions that require a fixed and prior
mapping" (section 4): an IR reflectance above 70 is a virtual collision, penalised and undone
by reversing. The shield uses the same sensors one step earlier: before an action is sent, it
predicts the clearance the move would leave and, if that would fall below ``margin``, replaces
the action by the nearest angle that keeps it (shielding, Alshiekh et al. 2018). Everything
else is left alone, so the learner, the reflex and the reward are those of the paper; only
moves into a wall are vetoed.

Why it is needed (docs/journal/learning.md): the remaining collisions of the learned controller
are the reflex's own swerves at the 1 m door (a post seen by a front ray, a 55 deg turn into the
other post). They are rare (1-5 % of trials per option), so a critic that averages a few trials per
option cannot see them.

Geometry, in the robot frame (x ahead, angles left-positive): IR sensor k looks along
``k * 360 / n`` deg and reports the nearest wall point within +-180/n deg of its axis, up to
``ir_range`` from the rim, as reflectance 100 (1 - d / ir_range)^3. The robot rotates by the
action, then moves ``step`` straight. For every sensor that sees a wall, the wall point is
assumed at the sector's two edges and its axis (the conservative reading of one number per
sector) and the smallest centre distance along the straight move gives the clearance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.world.robot import RobotConfig

__all__ = ["ShieldConfig", "IRShield"]

_FIRST = 48
"""Candidates of the smallest turns tried first by the search for a safe action."""


@dataclass(frozen=True)
class ShieldConfig:
    """How close a move may bring the rim to a wall, and how finely safe angles are searched."""

    margin: float = 0.06
    """Smallest predicted rim clearance a move may leave (metres). The env's virtual collision
    is a rim distance below 0.056 m (reflectance > 70), so 0.06 keeps a 4 mm reserve for the
    motion noise. Measured (tuning seeds): 0.03 lets collisions through, 0.06 and 0.10 none."""

    resolution_deg: float = 2.5
    """Spacing of the candidate angles searched when the proposed one is unsafe (degrees)."""

    def __post_init__(self) -> None:
        m = self.margin
        if not (isinstance(m, (int, float)) and math.isfinite(m) and m >= 0):
            raise ValueError(f"ShieldConfig.margin must be a number >= 0, got {self.margin!r}")
        r = self.resolution_deg
        if not (isinstance(r, (int, float)) and math.isfinite(r) and 0 < r <= 90):
            raise ValueError(f"ShieldConfig.resolution_deg must be in (0, 90], got {r!r}")


class IRShield(BufferViews):
    """Replace an action whose move would bring the rim within ``margin`` of a wall.

    ``forward(reflectance, action)`` is batched: ``reflectance`` (..., n) IR readings in
    [0, 100], ``action`` (...) turning angles (rad, left positive); returns the safe actions
    and a bool mask of the replaced ones. If no candidate angle is safe (boxed in), the one
    with the largest predicted clearance is taken. :meth:`filter` is the one-sample path of the
    control loop (it tests the proposed angle alone first, the common case).
    """

    bearings: torch.Tensor
    candidates: torch.Tensor

    def __init__(self, config: ShieldConfig | None = None, robot: RobotConfig | None = None):
        super().__init__()
        self.config = config or ShieldConfig()
        robot = robot or RobotConfig()
        self.radius, self.step, self.ir_range = robot.radius, robot.step, robot.ir_range
        self.n = robot.n_sensors
        half = math.pi / self.n
        axes = torch.arange(self.n, dtype=torch.float64) * (2 * math.pi / self.n)
        spread = torch.tensor([-half, 0.0, half], dtype=torch.float64)
        self.register_buffer("bearings", (axes[:, None] + spread).reshape(-1), persistent=False)
        step = math.radians(self.config.resolution_deg)
        count = int(round(2 * math.pi / step))
        grid = torch.arange(count, dtype=torch.float64) * (2 * math.pi / count) - math.pi
        self.register_buffer("candidates", grid, persistent=False)
        # A move shortens no rim distance by more than its length: while every IR reading is
        # at most this reflectance (rim distance >= margin + step), every move is safe.
        reach = min(self.config.margin + self.step, self.ir_range)
        self.quiet = 100.0 * (1.0 - reach / self.ir_range) ** 3 - 1e-6

    def distances(self, reflectance: torch.Tensor) -> torch.Tensor:
        """Rim distance per IR sensor (metres); ``inf`` where it sees nothing (reflectance 0)."""
        return torch.from_numpy(self._distances(reflectance.numpy()))

    def _distances(self, reflectance: np.ndarray) -> np.ndarray:
        # numpy on a handful of rows (a fraction of the torch dispatches); the cube root stays
        # torch's pow, whose last bit differs from libm's for some readings
        # clipped by min/max (np.clip's dispatch costs about twice as much; the same numbers)
        refl = np.minimum(np.maximum(reflectance.astype(np.float64), 0.0), 100.0)
        root = torch.from_numpy(refl / 100.0).pow_(1.0 / 3.0).numpy()
        return np.where(refl > 0, self.ir_range * (1.0 - root), np.inf)

    def clearance(self, reflectance: torch.Tensor, angles: torch.Tensor) -> torch.Tensor:
        """Predicted smallest rim clearance along the move for each angle.

        ``reflectance`` (..., n), ``angles`` (..., m) -> (..., m) metres (inf: nothing seen)."""
        rho = np.repeat(self._distances(reflectance.numpy()) + self.radius, 3, axis=-1)
        return torch.from_numpy(self._clearance(rho, self.bearings.numpy(), angles.numpy()))

    def _clearance(self, rho: np.ndarray, bearings: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """:meth:`clearance` from centre distances ``rho`` (..., b) at ``bearings`` (b,) or
        (..., b), in numpy with torch's cos (whose last bit differs from libm's)."""
        diff = bearings[..., None, :] - angles.astype(np.float64)[..., :, None]
        cos = torch.from_numpy(diff).cos_().numpy()
        rho = rho[..., None, :]  # (..., 1, b) against cos (..., m, b)
        with np.errstate(invalid="ignore"):  # inf * cos for a sensor that sees nothing
            # the closest point of the straight move (min/max: the cheaper np.clip)
            along = np.minimum(np.maximum(rho * cos, 0.0), self.step)
            sq = np.square(rho) - 2.0 * rho * along * cos + np.square(along)
        centre = np.where(np.isfinite(rho), np.sqrt(np.maximum(sq, 0.0)), np.inf)
        return centre.min(axis=-1) - self.radius

    def forward(
        self, reflectance: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        if action.dtype is not torch.float64:
            action = action.to(torch.float64)
        margin = self.config.margin
        refl_np, action_np = reflectance.numpy(), action.numpy()
        near = refl_np.max(axis=-1) > self.quiet  # the rows where a move could be unsafe
        if not near.any():
            return action, torch.from_numpy(near)
        some = np.flatnonzero(near)
        centre = np.repeat(self._distances(refl_np[some]) + self.radius, 3, axis=-1)
        unsafe_np = np.zeros_like(near)
        room_np = self._clearance(centre, self.arrays["bearings"], action_np[some][:, None])[:, 0]
        unsafe_np[some] = room_np < margin
        unsafe = torch.from_numpy(unsafe_np)
        if not unsafe_np.any():
            return action, unsafe
        # the candidate search runs only on the rows whose action is unsafe (the rare case), in
        # numpy as the test above (its torch ops cost several times as much at these sizes)
        rows = np.flatnonzero(unsafe_np)
        out = action_np.copy()
        out[rows] = self._search(refl_np[rows], action_np[rows])
        return torch.from_numpy(out), unsafe

    def _search(self, refl: np.ndarray, act: np.ndarray) -> np.ndarray:
        """The safe actions of unsafe rows (``refl`` (k, n), ``act`` (k,)): the candidate with
        the smallest turn from the proposed angle whose move keeps the margin (the first of
        equal turns), or the one with the largest clearance if none does.

        The candidates nearest in turn are tried first (``_FIRST`` of them, +-60 deg): a
        candidate's clearance is its own (each one computed on its own), so the first safe one
        among them, in the order of turn and then of index, is the one the whole grid would
        give. Only rows with none safe there search the whole grid (the search took a
        fifth of the policy's time at B = 10, in the one step in seven that needs it)."""
        margin = self.config.margin
        # only the sensors that see a wall constrain a move: search over those bearings alone
        seen = refl > 0
        width = max(int(seen.sum(-1).max()), 1)
        sensors = np.argsort(~seen, axis=-1, kind="stable")[:, :width]
        rho = np.repeat(
            self._distances(np.take_along_axis(refl, sensors, -1)) + self.radius, 3, axis=-1
        )
        bearings = self.arrays["bearings"].reshape(-1, 3)[sensors].reshape(len(act), -1)
        candidates = self.arrays["candidates"]
        grid = np.broadcast_to(candidates, (len(act), len(candidates)))
        # np.mod as torch.remainder (they differ only in the sign of a zero, which - pi drops)
        turn = np.abs(np.mod(grid - act[:, None] + math.pi, 2 * math.pi) - math.pi)
        order = np.argsort(turn, axis=-1, kind="stable")[:, :_FIRST]
        safe = self._clearance(rho, bearings, candidates[order]) >= margin
        out = candidates[np.take_along_axis(order, safe.argmax(axis=-1)[:, None], -1)[:, 0]]
        wide = np.flatnonzero(~safe.any(axis=-1))
        if len(wide):  # none near the proposed angle is safe: the whole grid
            room = self._clearance(rho[wide], bearings[wide], grid[wide])
            safe = room >= margin
            cost = np.where(safe, turn[wide], np.inf)
            nearest, widest = candidates[cost.argmin(axis=-1)], candidates[room.argmax(axis=-1)]
            out[wide] = np.where(safe.any(axis=-1), nearest, widest)
        return out

    def filter(self, reflectance: torch.Tensor, action: float) -> tuple[float, bool]:
        """One sample: ``(safe action, replaced?)``; the proposed angle is kept when safe."""
        values = reflectance.tolist()
        seen = [k for k, v in enumerate(values) if v > 0]
        if not seen:
            return action, False  # nothing within IR range: every move is safe
        # the common case, in plain floats (~20x cheaper than tensor ops): is the move safe?
        margin, radius, step, ir_range = self.config.margin, self.radius, self.step, self.ir_range
        width = 2 * math.pi / self.n
        smallest = math.inf
        for k in seen:
            rho = radius + ir_range * (1.0 - (min(values[k], 100.0) / 100.0) ** (1.0 / 3.0))
            for edge in (-0.5, 0.0, 0.5):
                c = math.cos((k + edge) * width - action)
                t = min(max(rho * c, 0.0), step)
                smallest = min(smallest, math.sqrt(max(rho * rho - 2 * rho * t * c + t * t, 0)))
        if smallest - radius >= margin:
            return action, False
        index = torch.tensor([3 * k + j for k in seen for j in range(3)])
        rho = (self.distances(reflectance) + self.radius).repeat_interleave(3)[index]
        bearings = self.bearings[index]
        grid = self.candidates
        room = torch.from_numpy(self._clearance(rho.numpy(), bearings.numpy(), grid.numpy()))
        safe = room >= margin
        if not bool(safe.any()):
            return float(grid[room.argmax()]), True
        turn = torch.remainder(grid - float(action) + math.pi, 2 * math.pi) - math.pi
        return float(grid[torch.where(safe, turn.abs(), torch.inf).argmin()]), True
