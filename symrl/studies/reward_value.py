"""Stage 1 of the reward optimum's search: a value table of what is left to earn from a
position, by value iteration on a grid (a guess, only used to rank the beam's sequences)."""

from __future__ import annotations

import math

import numpy as np
from tqdm import tqdm

from symrl.studies.reward_rollout import TWO_PI, no_rngs, robots_at
from symrl.world.physics import RobotBatch
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap

_CHUNK = 20_000  # robots stepped in one batch by the value table


class ValueTable:
    """What is left to earn from a position, by value iteration on a grid (a guess: the grid
    and the heading set are coarse; only used to rank the beam)."""

    def __init__(
        self,
        world: WorldMap,
        robot: RobotConfig,
        spacing: float,
        n_headings: int,
        bar: tqdm | None = None,
    ) -> None:
        xmin, xmax, ymin, ymax = world.bounds
        self.x0, self.y0, self.s = xmin, ymin, spacing
        xs = np.arange(xmin, xmax + spacing / 2, spacing)
        ys = np.arange(ymin, ymax + spacing / 2, spacing)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        px, py = gx.ravel(), gy.ravel()
        walls = RobotBatch(world, robot, 1, noise=False).walls
        ok = world.in_free_area(px, py)
        ok[ok] = walls.clearance(np.column_stack([px[ok], py[ok]])) > robot.radius
        idx = np.flatnonzero(ok)
        k = n_headings
        angles = -math.pi + TWO_PI * np.arange(k) / k
        n = len(idx)
        reward, done = np.empty((n, k)), np.empty((n, k), dtype=bool)
        nx, ny = np.empty(n * k), np.empty(n * k)
        rows = max(1, _CHUNK // k)  # grid points per batch: bounded memory on big maps
        for a in range(0, n, rows):
            b = min(a + rows, n)
            bx, by = np.repeat(px[idx[a:b]], k), np.repeat(py[idx[a:b]], k)
            batch = robots_at(world, robot, bx, by, np.zeros(len(bx)))
            r = batch.step(np.tile(angles, b - a), no_rngs(len(bx)))
            reward[a:b] = np.where(r.collision, -np.inf, r.reward).reshape(b - a, k)
            done[a:b] = r.reached_goal.reshape(b - a, k)
            nx[a * k : b * k], ny[a * k : b * k] = r.true_pose[:, 0], r.true_pose[:, 1]
        self.shape = gx.shape
        value = np.zeros(len(px))
        valid = np.zeros(len(px), dtype=bool)
        valid[idx] = True
        self.valid = valid
        corners, weights = self._corners(nx, ny)
        for _ in range(2000):
            grid = np.where(valid, value, np.nan)
            later = self._interpolate(grid, corners, weights).reshape(n, k)
            new = np.max(reward + np.where(done, 0.0, later), axis=1)
            change = np.nanmax(np.abs(new - value[idx])) if n else 0.0
            value[idx] = np.maximum(new, -1e3)
            if bar is not None:
                bar.set_postfix_str(f"value table: change {change:.2g}")
            if change < 1e-9:
                break
        self.value = self._fill(np.where(valid, value, np.nan))

    def _corners(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nx, ny = self.shape
        fx, fy = (x - self.x0) / self.s, (y - self.y0) / self.s
        i, j = (
            np.clip(np.floor(fx).astype(int), 0, nx - 2),
            np.clip(np.floor(fy).astype(int), 0, ny - 2),
        )
        tx, ty = np.clip(fx - i, 0, 1), np.clip(fy - j, 0, 1)
        corners = np.stack([i * ny + j, (i + 1) * ny + j, i * ny + j + 1, (i + 1) * ny + j + 1])
        weights = np.stack([(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty])
        return corners, weights

    @staticmethod
    def _interpolate(grid: np.ndarray, corners: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Bilinear over the valid corners (their weights renormalised); -1e3 where none is."""
        v = grid[corners]
        w = np.where(np.isnan(v), 0.0, weights)
        total = w.sum(axis=0)
        out = np.full(v.shape[1], -1e3)
        some = total > 1e-12
        out[some] = (np.nan_to_num(v) * w).sum(axis=0)[some] / total[some]
        return out

    def _fill(self, grid: np.ndarray) -> np.ndarray:
        """Grid points off the free area take their best valid neighbour's value (two rings),
        so positions within a cell of a wall still read a value."""
        g = grid.reshape(self.shape)
        for _ in range(2):
            padded = np.pad(g, 1, constant_values=np.nan)
            stack = np.stack(
                [
                    padded[1 + dx : 1 + dx + g.shape[0], 1 + dy : 1 + dy + g.shape[1]]
                    for dx in (-1, 0, 1)
                    for dy in (-1, 0, 1)
                ]
            )
            best = np.where(
                np.all(np.isnan(stack), axis=0),
                np.nan,
                np.nanmax(np.where(np.isnan(stack), -np.inf, stack), axis=0),
            )
            g = np.where(np.isnan(g), best, g)
        return g.ravel()

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        corners, weights = self._corners(x, y)
        return self._interpolate(self.value, corners, weights)
