"""Where each border can be crossed, learned by each robot from its own sonar and odometry.

The region rules fix where two regions meet (a *border*, :class:`symrl.knowledge.borders.Border`)
but not whether a wall stands on it or where its door is. A robot told only the rules
(``knowledge: regions``) finds that out as it drives: every sonar ray that meets a border's line
says something about the point where it meets it. A ray whose echo comes from beyond the line
shows the line *open* there; an echo from the line itself, or from less than a body radius before
it, shows it *blocked* there (the robot could not reach the line at that point); an echo from
farther before the line shows the point *hidden* behind another wall, when the ray was cast from
one of the border's two regions (from a third region the wall in between may be one the robot
would pass round on its way to them, so the line stays unseen). Where the robot crosses a
border (its believed pose changes region across the line) the line is open for a body width.

The evidence is kept per robot and border, in bins of ``resolution`` metres along the line,
across trials: it is learned, as the experts are. The pose it is placed from is the odometry's,
which drifts as a trial goes on (the rotation noise integrates), so a ray counts by how sure its
point is to a bin (the robot's own motion model says how far the odometry may have drifted after
n actions), and the latest scan also counts at full weight: it is in the frame the robot steers
by now, however far that frame has drifted.

A border's crossings are the stretches of bins not shown blocked that are at least the robot's
diameter wide; the robot aims at a point of one of them, kept a body radius plus the reward's
close distance from its ends (the middle of a narrower stretch). Stretches seen open are
preferred; else stretches never seen; a stretch seen only behind other walls is none (the robot
looked that way and something stands between), unless the options ask for the border as a way
on the rules' graph cannot do without (``hidden_too``). Among them it takes the one that makes the
straight way robot -> crossing -> goal shortest. A border with no crossing left is *blocked*,
and the options (:class:`symrl.learner.options.SubgoalOptions`) route the region graph around
it. Nothing here reads the walls: only the rules' lines, the robot's size, sensors and motion
model, its readings and its odometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.knowledge.borders import Border
from symrl.world.robot import odometry_drift

__all__ = ["CrossingMap", "Crossing"]

_SURE = 0.5
"""The evidence of one ray (weight 1 when the odometry is exact) that a bin needs, halved."""

Crossing = tuple[float, float, float]
"""A crossing chosen: (t along the line, the stretch's first bin, its last bin)."""


class CrossingMap(BufferViews):
    """The crossing evidence of B robots over the borders ``borders``.

    Buffers (per robot, J borders, N bins: the longest border's; ``bins`` (J,) says how many
    each has): ``open``, ``blocked`` and ``hidden`` (B, J, N) float32, the weight of the rays
    (and crossings) that showed each bin open, blocked, or behind another wall (learned, kept
    across trials), and ``fresh_*`` the same of the latest scan alone (not saved).
    """

    open: torch.Tensor
    blocked: torch.Tensor

    def __init__(
        self,
        borders: Sequence[Border],
        batch: int,
        *,
        radius: float,
        close_distance: float,
        sonar_range: float,
        n_sensors: int,
        origin: tuple[float, float],
        reach: float,
        resolution: float,
        dead_ends: bool = False,
        step: float = 0.0,
        translation_noise: float = 0.0,
        rotation_noise: float = 0.0,
        region_names: Sequence[str] = (),
    ) -> None:
        """``radius``: the robot's body radius; ``close_distance``: the reward's wall distance
        (a crossing is aimed at that far from a stretch's ends, past the body); ``origin``: the
        start, and ``reach``: how far from it the robot can get and still sense (an unbounded
        border is binned that far either side of the start); ``step``, ``translation_noise``
        (a fraction of the step) and ``rotation_noise`` (radians): the robot's model of its own
        motion, whose odometry drifts as a trial goes on: a ray counts as passing the line
        only when its echo lies beyond it by more than the drift could account for;
        ``dead_ends``: mark the stretches that led into a dead end (:meth:`cross`);
        ``region_names``: the regions' names in the order of the region indices :meth:`observe`
        is given (a ray hidden before a border counts only from one of the border's two
        regions)."""
        super().__init__()
        self.borders = tuple(borders)
        self.radius = float(radius)
        self.inset = float(radius + close_distance)
        self.sonar_range = float(sonar_range)
        self.resolution = float(resolution)
        self.dead_ends = bool(dead_ends)
        self.tolerance = 0.5 * self.resolution  # an echo this far past the line hit the line
        j = len(self.borders)
        self.axis = np.array([b.axis for b in self.borders], dtype=np.int64)
        self.intercept = np.array([b.intercept for b in self.borders], dtype=np.float64)
        lo, hi = [], []
        for b in self.borders:
            along = origin[1] if b.axis == 0 else origin[0]
            lo.append(max(b.lo, along - reach))
            hi.append(min(b.hi, along + reach))
        self.lo = np.array(lo, dtype=np.float64)
        self.hi = np.array(hi, dtype=np.float64)
        self.bins = np.maximum(np.ceil((self.hi - self.lo) / self.resolution), 1).astype(np.int64)
        n = int(self.bins.max()) if j else 1
        self.register_buffer("open", torch.zeros(batch, j, n, dtype=torch.float32))
        self.register_buffer("blocked", torch.zeros(batch, j, n, dtype=torch.float32))
        self.register_buffer("hidden", torch.zeros(batch, j, n, dtype=torch.float32))
        if self.dead_ends:  # per border and direction (0: toward its high side, 1: toward its
            # low side), the bins of a stretch that led into a dead end: crossed there, trapped,
            # and back out there
            self.register_buffer("dead", torch.zeros(batch, j, 2, n, dtype=torch.bool))
        # the latest scan alone, at full weight: it is in the frame of the odometry the robot
        # steers by now, however far that has drifted
        for name in ("fresh_open", "fresh_blocked", "fresh_hidden"):
            self.register_buffer(
                name, torch.zeros(batch, j, n, dtype=torch.float32), persistent=False
            )
        self._angles = np.arange(n_sensors, dtype=np.float64) * (2 * math.pi / n_sensors)
        self._exists = np.arange(n)[None, :] < self.bins[:, None]  # (J, N)
        self._rows = np.arange(batch)
        self._step, self._move, self._turn = (
            float(step),
            float(translation_noise),
            float(rotation_noise),
        )
        self._seen_steps = np.zeros(batch, dtype=np.int64)  # observations in this trial
        # the trial's last crossing per robot: border (-1: none yet), where, which direction
        self._entry = np.full(batch, -1, dtype=np.int64)
        self._entry_t = np.zeros(batch)
        self._entry_way = np.zeros(batch, dtype=np.int64)
        self._trapped = np.zeros(batch, dtype=bool)  # trapped on its way on since then
        self._following = np.zeros(batch, dtype=bool)  # following a wall at the last step
        # (R, J): region r is one of border j's two regions
        self._joins = np.array(
            [[name in (b.low, b.high) for b in self.borders] for name in region_names],
            dtype=bool,
        ).reshape(len(region_names), j)
        self._between: dict[tuple[str, str], list[int]] = {}
        for i, b in enumerate(self.borders):
            self._between.setdefault((b.low, b.high), []).append(i)
            self._between.setdefault((b.high, b.low), []).append(i)

    # -- evidence (the update calls these) -------------------------------------------------
    def observe(
        self, pose: np.ndarray, sonar: np.ndarray, region: np.ndarray | None = None
    ) -> None:
        """Every robot's sonar rays (``sonar`` (B, n) rim distances in metres, capped at the
        range) from its believed ``pose`` (B, 3), as evidence on every border they meet;
        ``region`` (B,) the region each robot is in (indices into ``region_names``).

        A ray stopped before a border shows it hidden only when cast from one of the border's
        two regions: there something stands between that region and the line. Cast from a
        third region it says nothing of the line (the wall in between may be one the robot
        would pass round on its way to that region), so the border stays unseen there."""
        self.observe_rows(self._rows, pose, sonar, region)

    def observe_rows(
        self,
        rows: np.ndarray,
        pose: np.ndarray,
        sonar: np.ndarray,
        region: np.ndarray | None = None,
    ) -> None:
        """:meth:`observe` for robots ``rows`` (k,) only (``pose`` (k, 3), ``sonar`` (k, n),
        ``region`` (k,))."""
        if not len(self.borders) or not len(rows):
            return
        angle = pose[:, 2:3] + self._angles  # (B, n)
        cos, sin = np.cos(angle), np.sin(angle)
        axis = self.axis[None, :, None]  # (1, J, 1)
        across = np.where(axis == 0, cos[:, None, :], sin[:, None, :])  # (B, J, n)
        along = np.where(axis == 0, sin[:, None, :], cos[:, None, :])
        own = np.where(self.axis[None, :] == 0, pose[:, 0:1], pose[:, 1:2])  # (B, J)
        other = np.where(self.axis[None, :] == 0, pose[:, 1:2], pose[:, 0:1])
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (self.intercept[None, :] - own)[:, :, None] / across  # distance to the line
        t = other[:, :, None] + s * along
        echo = sonar[:, None, :] + self.radius  # from the centre
        seen = sonar[:, None, :] < self.sonar_range  # an echo (else nothing within range)
        valid = (s > self.radius) & (s < self.sonar_range + self.radius) & np.isfinite(s)
        valid &= (t >= self.lo[None, :, None]) & (t < self.hi[None, :, None])
        # two standard deviations of the odometry's drift after n actions, along the ray: the
        # position's (the heading's error integrated along the path) and the heading's at s
        n = self._seen_steps[rows].astype(np.float64)
        heading = self._turn * np.sqrt(n)
        position = odometry_drift(n, self._step, self._move, self._turn)
        with np.errstate(invalid="ignore"):
            drift = np.sqrt(position[:, None, None] ** 2 + (s * heading[:, None, None]) ** 2)
        tolerance = self.tolerance + 2 * drift
        # a ray counts as much as its point on the line is sure to a bin: an odometry that has
        # drifted by several bins places it nowhere in particular
        weight = 1.0 / (1.0 + (drift / self.resolution) ** 2)
        with np.errstate(invalid="ignore"):  # rays parallel to a line: not valid, masked here
            passed = valid & (~seen | (echo > s + tolerance))
            stopped = valid & seen & (echo >= s - self.radius) & (echo <= s + tolerance)
            hidden = valid & seen & (echo < s - self.radius)
        if region is not None and len(self._joins):
            hidden &= self._joins[region][:, :, None]
        self._seen_steps[rows] += 1
        a, one = self.arrays, np.ones_like(weight)
        for name, mask in (("open", passed), ("blocked", stopped), ("hidden", hidden)):
            self._add(a[name], rows, mask, t, weight)
            a[f"fresh_{name}"][rows] = 0.0
            self._add(a[f"fresh_{name}"], rows, mask, t, one)

    def _add(
        self,
        counts: np.ndarray,
        rows: np.ndarray,
        mask: np.ndarray,
        t: np.ndarray,
        weight: np.ndarray,
    ) -> None:
        if not mask.any():
            return
        b, j, _ = np.nonzero(mask)
        i = ((t[mask] - self.lo[j]) / self.resolution).astype(np.int64)
        np.add.at(counts, (rows[b], j, np.minimum(i, self.bins[j] - 1)), weight[mask])

    def _states(self, row: int, border: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Robot ``row``'s bins of ``border``: seen open, seen blocked, seen hidden (each
        needs the weight of one sure ray; blocked and open by the larger)."""
        a, n = self.arrays, int(self.bins[border])
        opened = a["open"][row, border, :n] + a["fresh_open"][row, border, :n]
        shut = a["blocked"][row, border, :n] + a["fresh_blocked"][row, border, :n]
        hidden = a["hidden"][row, border, :n] + a["fresh_hidden"][row, border, :n] >= _SURE
        blocked = (shut >= _SURE) & (shut > opened)
        return (opened >= _SURE) & ~blocked, blocked, hidden

    def watch(self, following: np.ndarray, aiming: np.ndarray) -> None:
        """Every robot's wall follow at this step (B,) bool (``options.wall_follow``) and the
        border its option leads across (B,) (-1: the goal): a follow that began since the
        robot's last crossing, its option leading on, is a trap met beyond that crossing. A
        follow carried across the line, or begun while aiming back across it, says nothing of
        what lies beyond."""
        if not self.dead_ends:
            return
        began = following & ~self._following
        self._following[:] = following
        self._trapped |= began & (aiming != self._entry)

    def cross(self, row: int, before: str, after: str, xy: np.ndarray, xy_next: np.ndarray) -> None:
        """Robot ``row`` moved from region ``before`` at ``xy`` to ``after`` at ``xy_next``:
        every border between the two that the move crosses is open where it crossed. When the
        robot was trapped on its way on since its last crossing (:meth:`watch`) and now
        crosses that same border back the other way, within the stretch it came in by (the run
        of bins not seen blocked), that stretch led into a dead end: it is marked so for that
        direction (it stays open, and is taken only when no other stretch is left)."""
        for j in self._between.get((before, after), ()):
            a, c = int(self.axis[j]), float(self.intercept[j])
            d = xy_next[a] - xy[a]
            if d == 0 or (xy[a] - c) * (xy_next[a] - c) > 0:
                continue
            f = (c - xy[a]) / d
            t = float(xy[1 - a] + f * (xy_next[1 - a] - xy[1 - a]))
            if not self.lo[j] <= t < self.hi[j]:
                continue
            way = 0 if d > 0 else 1  # toward the high side, or the low
            back = self._entry[row] == j and self._entry_way[row] != way
            if self._trapped[row] and back:
                first, last = self._run(row, j, self._entry_t[row])
                if first <= self._span(j, t, t)[0] <= last:  # out the way it came in
                    self.arrays["dead"][row, j, 1 - way, first : last + 1] = True
            self._entry[row], self._entry_t[row], self._entry_way[row] = j, t, way
            self._trapped[row] = False
            self.crossed(row, j, t)

    def _run(self, row: int, border: int, t: float) -> tuple[int, int]:
        """The first and last bin of the run of ``border``'s bins not seen blocked around ``t``
        (robot ``row``'s evidence)."""
        _, shut, _ = self._states(row, border)
        i = self._span(border, t, t)[0]
        walls = np.flatnonzero(shut)
        first = int(walls[walls < i].max()) + 1 if (walls < i).any() else 0
        last = int(walls[walls > i].min()) - 1 if (walls > i).any() else len(shut) - 1
        return first, last

    def crossed(self, row: int, border: int, t: float) -> None:
        """Robot ``row`` crossed ``border`` at ``t`` along its line: open for a body width."""
        first, last = self._span(border, t - self.radius, t + self.radius)
        if first <= last:
            self.arrays["open"][row, border, first : last + 1] += 1.0

    def forget(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial: their odometry is exact again, and no scan is new."""
        a = self.arrays
        for name in ("fresh_open", "fresh_blocked", "fresh_hidden"):
            a[name][rows] = 0.0
        self._seen_steps[rows] = 0
        self._entry[rows] = -1
        self._trapped[rows] = False
        self._following[rows] = False

    def _span(self, border: int, t0: float, t1: float) -> tuple[int, int]:
        n = int(self.bins[border])
        first = max(int(math.floor((t0 - self.lo[border]) / self.resolution)), 0)
        last = min(int(math.floor((t1 - self.lo[border]) / self.resolution)), n - 1)
        return first, last

    # -- reading (the options call these) ---------------------------------------------------
    def crossing(
        self,
        row: int,
        border: int,
        xy: np.ndarray,
        goal: tuple[float, float],
        hidden_too: bool = False,
    ) -> Crossing | None:
        """Where robot ``row`` at ``xy`` should cross ``border`` on its way to ``goal``: the
        point ``t`` along the line and the stretch it lies in (first and last bin); None when
        the robot has found the border blocked. With ``hidden_too``, a stretch seen only behind
        other walls is a crossing too, the last kind taken (the options ask so for a border the
        rules' graph cannot do without: the wall between may be passed round); None then only
        where the border was seen blocked along its whole length, or in stretches too narrow
        for the body."""
        opened, shut, behind = self._states(row, border)
        free = ~shut
        if not free.any():
            return None
        # runs of free bins: starts and ends (inclusive)
        edges = np.diff(np.concatenate(([0], free.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        res, lo = self.resolution, float(self.lo[border])
        wide = (ends - starts + 1) * res >= 2 * self.radius
        if not wide.any():
            return None
        starts, ends = starts[wide], ends[wide]
        # stretches seen open first; else stretches never seen, not those seen only behind
        # other walls (the robot has looked that way, and something stands between)
        runs = list(zip(starts.tolist(), ends.tolist(), strict=True))
        seen_open = np.array([bool(opened[s : e + 1].any()) for s, e in runs])
        hidden = np.array([bool(behind[s : e + 1].any()) for s, e in runs])
        # a stretch that led into a dead end going this way comes last
        b = self.borders[border]
        dead = np.zeros(len(runs), dtype=bool)
        if self.dead_ends:
            way = 0 if (xy[0] if b.axis == 0 else xy[1]) < b.intercept else 1
            dead_bins = self.arrays["dead"][row, border, way]
            dead = np.array([bool(dead_bins[s : e + 1].any()) for s, e in runs])
        keep = np.zeros(len(runs), dtype=bool)
        kinds = [seen_open & ~dead, ~hidden & ~dead, (seen_open | ~hidden) & dead]
        if hidden_too:
            kinds += [~dead, dead]
        for kind in kinds:
            if kind.any():
                keep = kind
                break
        if not keep.any():
            return None
        starts, ends = starts[keep], ends[keep]
        goal_t = goal[1] if b.axis == 0 else goal[0]
        best: Crossing | None = None
        best_cost = math.inf
        for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
            t0, t1 = lo + s * res, lo + (e + 1) * res
            inset = min(self.inset, (t1 - t0) / 2)
            t = min(max(goal_t, t0 + inset), t1 - inset)
            p = b.at(t)
            cost = math.hypot(p[0] - xy[0], p[1] - xy[1]) + math.hypot(
                goal[0] - p[0], goal[1] - p[1]
            )
            if cost < best_cost:
                best, best_cost = (t, float(s), float(e)), cost
        return best

    def seen(self, row: int, border: int) -> tuple[np.ndarray, np.ndarray]:
        """Robot ``row``'s view of ``border``: the bins' centres along the line (n,) and their
        state (n,) int: 0 unknown, 1 open, 2 blocked, 3 led into a dead end one way or the
        other (and not blocked) (figures, logging)."""
        n = int(self.bins[border])
        centres = self.lo[border] + (np.arange(n) + 0.5) * self.resolution
        opened, shut, _ = self._states(row, border)
        state = np.zeros(n, dtype=np.int64)
        state[opened] = 1
        state[shut] = 2
        if self.dead_ends:
            state[self.arrays["dead"][row, border, :, :n].any(axis=0) & ~shut] = 3
        return centres, state

    def summary(self, row: int, hidden_too: np.ndarray | None = None) -> dict[str, object]:
        """Robot ``row``'s belief in a few numbers and as stretches (trial records, TensorBoard,
        figures): metres of the borders seen open and seen blocked (and, with ``dead_ends``,
        that led into a dead end, not counted open), the borders with no crossing left (those
        of ``hidden_too`` (J,) bool counting their stretches seen only behind other walls, as
        :meth:`crossing` does for them), and ``stretches``: per border, runs
        ``[t0, t1, state]`` of one state (:meth:`seen`'s codes)."""
        opened = shut = dead = 0.0
        blocked = 0
        stretches = []
        for j in range(len(self.borders)):
            centres, state = self.seen(row, j)
            opened += float((state == 1).sum()) * self.resolution
            shut += float((state == 2).sum()) * self.resolution
            dead += float((state == 3).sum()) * self.resolution
            goal = (0.0, 0.0)
            hidden = hidden_too is not None and bool(hidden_too[j])
            blocked += self.crossing(row, j, np.zeros(2), goal, hidden_too=hidden) is None
            edges = np.flatnonzero(np.diff(state)) + 1
            runs = []
            for a, b in zip(np.r_[0, edges], np.r_[edges, len(state)], strict=True):
                lo, hi = centres[a] - self.resolution / 2, centres[b - 1] + self.resolution / 2
                runs.append([round(float(lo), 3), round(float(hi), 3), int(state[a])])
            stretches.append(runs)
        return {
            "crossings_open_m": round(opened, 3),
            "crossings_blocked_m": round(shut, 3),
            "borders_blocked": int(blocked),
            **({"crossings_dead_end_m": round(dead, 3)} if self.dead_ends else {}),
            "stretches": stretches,
        }
