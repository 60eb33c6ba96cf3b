"""The best trial's way, remembered and pulled tight where the trial's own echoes leave room.

The options say where the reflex steers in each region (the goal, a border's crossing), and
where a wall no region line marks stands in the way (a thin wall, an island) the reflex's
avoidance slides the robot along it to its end, trial after trial. The robot's own best trial
holds a better way. After each shorter successful trial, each robot keeps that trial's path in
its odometry and pulls it tight backward from where the trial ended (the goal, in that trial's
odometry): the earliest pose from which the straight way there stayed within the sonar's range
and kept the body and the reward's close distance off every echo the trial read (each placed
from the odometry pose it was read at) is the last via-point, the earliest pose from which the
way to that one did the one before, and so on back to the start.

The way belongs to the options that trial chose: a later trial steers at the via-points in turn,
then at the goal, while the option chosen in every region it has entered is one the best trial
chose there (the one it entered the region with, or the one in force at its end, when the first
was given up), and until the robot's latest scan shows the straight way to the options' own aim
clear where the way leads too (the way is for walls that hide the aim; once none does, the
options steer). A wall may hide the next region's aim where none hid this one's (past a door, a
thin wall across the goal's bearing): once a trial the options steered from plain sight ends
longer than the way itself (its legs over the step, by a tenth and 3 actions), the robot takes
its way again at each new region or option it meets on the way (within the body and the
clearance of a leg), from that leg's end; until then the options steer for the rest of the
trial, which is as good wherever nothing hides the next aim. An option explored or given up
elsewhere, or a via-point not reached within 1.5 times the straight way's actions, hands the
steering back to the options for the rest of the trial. With one way per option of the region
the trials start in (``options.way_per_start_option``), a trial takes the way of the option it
starts with: the best trial's that began or ended there with it, so a start the critic comes to
prefer to the best trial's has a way of its own. After two trials in a row that took the
way and ended longer than the best by more than a tenth (and 3 actions), the way is left to the
options until a shorter trial gives a new one, or a trial the options steered alone ends longer
than the best by as much (the way is taken again). A shorter successful trial replaces the way,
so it is refined as the robot learns.

Nothing here reads the walls or searches a map: only the robot's odometry, sonar readings,
option choices and returns. ``tests/learner/test_remembered_way.py`` checks the pulled way
against a wall it must not cut.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews

__all__ = ["RememberedWay"]

_NONE = 1 << 30
"""``best`` before any successful trial."""
_MISSES = 2
"""Trials in a row that took the way and ended longer than the best by more than a tenth (and 3
actions) before the way is left to the options, until a shorter trial gives a new one (one the
noise made longer, between trials that took the way as well as the best, is no sign the way is
stale)."""


class RememberedWay(BufferViews):
    """The remembered ways of B robots over R regions, K per robot (one per start option).

    Buffers (learned, saved): ``points`` (B, K, M, 2) the via-points, ``count`` (B, K) how
    many, ``choices`` (B, K, R) the option the best trial chose in each region (-1: not
    entered), ``best`` (B, K) its actions, ``misses`` (B, K) the trials in a row that took the
    way and did worse, ``origin`` (B, K, 2) where the best trial began, ``past_sight`` (B, K)
    whether the way is taken again past the options' plain sight.
    """

    points: torch.Tensor
    count: torch.Tensor
    choices: torch.Tensor
    best: torch.Tensor
    misses: torch.Tensor
    origin: torch.Tensor
    past_sight: torch.Tensor

    def __init__(
        self,
        batch: int,
        regions: int,
        *,
        goal: tuple[float, float],
        goal_radius: float,
        radius: float,
        clearance: float,
        sonar_range: float,
        n_sensors: int,
        step: float,
        max_points: int,
        reach: float = 0.5,
        slack: float = 1.5,
        take_past_sight: bool = True,
        start_options: int = 1,
        spare_goal_search: bool = False,
    ) -> None:
        """``goal`` (the point steered at after the last via-point) and the radius of its disc;
        the robot's ``radius``, the ``clearance`` kept from the echoes beyond it, its sonar and
        ``step`` length; room for ``max_points`` via-points (the actions of a trial: a way has
        at most one per pose); a via-point nearer than ``reach`` is passed; one not reached
        within ``slack`` times the straight way's actions ends the way for the trial; with
        ``take_past_sight``, the way is taken again past the options' plain sight once they did
        worse from there than the way (``options.way_past_sight``); ``start_options`` ways
        per robot, one for each option its trials may start with (the start region's: row
        ``b * start_options + k`` is robot ``b``'s way for option ``k``; 1: one way, the best
        trial's whichever option it started with); with ``spare_goal_search``, a trial that
        had to search for its goal (:meth:`learn`'s ``goal_searched``) is no miss of the
        way."""
        super().__init__()
        self.goal = np.array(goal, dtype=np.float64)
        self.goal_radius = float(goal_radius)
        self.radius = float(radius)
        self.clearance = float(clearance)
        self.sonar_range = float(sonar_range)
        self.step = float(step)
        self.reach = float(reach)
        self.slack = float(slack)
        self.take_past_sight = bool(take_past_sight)
        self.start_options = int(start_options)
        self.spare_goal_search = bool(spare_goal_search)
        ways = (batch, self.start_options)
        self._angles = np.arange(n_sensors, dtype=np.float64) * (2 * math.pi / n_sensors)
        self.register_buffer("points", torch.zeros(*ways, max_points, 2, dtype=torch.float64))
        self.register_buffer("count", torch.zeros(ways, dtype=torch.long))
        self.register_buffer("choices", torch.full((*ways, regions), -1, dtype=torch.long))
        self.register_buffer("first", torch.full((*ways, regions), -1, dtype=torch.long))
        self.register_buffer("best", torch.full(ways, _NONE, dtype=torch.long))
        self.register_buffer("misses", torch.zeros(ways, dtype=torch.long))
        self.register_buffer("past_sight", torch.zeros(ways, dtype=torch.bool))
        self.register_buffer("origin", torch.zeros(*ways, 2, dtype=torch.float64))
        # per trial (not saved: a trial starts afresh)
        self._trial = {
            "next": np.zeros(batch, dtype=np.int64),  # the via-point aimed at
            "left": np.full(batch, -1.0),  # actions left to reach it (-1: not set yet)
            "off": np.zeros(batch, dtype=bool),  # the way given up for this trial
            "seen": np.zeros(batch, dtype=bool),  # the options' aim in plain sight
            "seen_at": np.full((batch, regions), -1, dtype=np.int64),  # the choices then
            "used": np.zeros(batch, dtype=bool),  # on the way at some step of the trial
            "following": np.zeros(batch, dtype=bool),  # on the way at the last step
            "way": np.full(batch, -1, dtype=np.int64),  # the row of the way for this trial
            "start": np.full(batch, -1, dtype=np.int64),  # the region it started in
        }

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):  # type: ignore[no-untyped-def]
        # a checkpoint written before the ways per start option holds one way per robot, its
        # buffers without the K axis: the same way as K = 1
        for name, buffer in self._buffers.items():
            saved = state_dict.get(prefix + name)
            older = saved is not None and buffer is not None and saved.dim() == buffer.dim() - 1
            if older and self.start_options == 1:
                state_dict[prefix + name] = saved.unsqueeze(1)
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    @property
    def ways(self) -> dict[str, np.ndarray]:
        """The buffers' numpy views with one row per way (B * start_options, ...): row
        ``b * start_options + k`` is robot ``b``'s way for start option ``k`` (views of the
        same memory: writes reach the buffers)."""
        views = self._views.get("ways")
        if views is None:
            views = {n: v.reshape(-1, *v.shape[2:]) for n, v in self.arrays.items()}
            assert all(np.shares_memory(v, self.arrays[n]) for n, v in views.items())
            self._views["ways"] = views
        return views

    @property
    def following(self) -> np.ndarray:
        """Which robots steered by the way at the last step (B,) bool (the options' timeout
        waits while they do: the way has its own)."""
        return self._trial["following"]

    def begin_trial(self, rows: np.ndarray) -> None:
        """Robots ``rows`` start a trial: on their way again, from its first via-point."""
        t = self._trial
        t["next"][rows] = 0
        t["left"][rows] = -1.0
        t["way"][rows] = -1
        t["start"][rows] = -1
        for name in ("off", "seen", "used", "following"):
            t[name][rows] = False

    # -- acting ---------------------------------------------------------------------------
    def aim(
        self,
        choice: np.ndarray,
        pose: np.ndarray,
        aim: np.ndarray,
        sonar: np.ndarray | None = None,
    ) -> np.ndarray:
        """The point each robot at odometry ``pose`` (B, 3) steers at (B, 2): on its remembered
        way (the options chosen so far in the trial, ``choice`` (B, R), -1 not entered, are the
        best trial's), its next via-point, then the goal; else ``aim``, the options' own. Once
        the latest scan (``sonar`` (B, n) over the range) shows the straight way to the options'
        aim clear (to the goal's disc when the aim is the goal) and the way leads there too (its
        next point farther off than the body and the clearance lies within them of that
        straight way), the way hands the steering back to the options for the rest of the
        trial: the way is for walls that hide the aim, and where nothing does, the options'
        aim (lined up with a crossing, refined by the experts) does better than the best
        trial's path, wiggles and all. A robot whose options did worse from plain sight than
        its way (``past_sight``) takes the way again at the next region or option, if it is
        still on it."""
        xy = pose[:, :2]
        a, t = self.ways, self._trial
        entered = choice >= 0
        w = self._trial_rows(choice)
        other = (choice != a["choices"][w]) & (choice != a["first"][w])
        t["off"] |= (entered & other).any(axis=1)
        moved_on = t["seen"] & a["past_sight"][w] & (choice != t["seen_at"]).any(axis=1)
        for b in np.flatnonzero(moved_on).tolist():  # a new region or option
            t["seen_at"][b] = choice[b]
            ahead, gap = self._ahead(int(w[b]), xy[b])
            if gap <= self.radius + self.clearance:  # still on the way: it steers again
                t["seen"][b] = False
                t["next"][b] = ahead
                t["left"][b] = -1.0
        use = (a["best"][w] < _NONE) & ~t["off"] & ~t["seen"] & (a["misses"][w] < _MISSES)
        out = aim.copy()
        if sonar is not None and use.any():
            for b in np.flatnonzero(use).tolist():
                echoes = self._echoes(pose[b : b + 1], sonar[b : b + 1])
                target = aim[b]
                if np.array_equal(target, self.goal):  # the options aim at the goal itself
                    target = self._goal_edge(xy[b])
                if self._clear(xy[b], target, echoes, both_ends=True) and self._agrees(
                    b, int(w[b]), xy[b], target
                ):
                    t["seen"][b] = True
                    t["seen_at"][b] = choice[b]
                    use[b] = False
        for b in np.flatnonzero(use).tolist():
            n, points = int(a["count"][w[b]]), a["points"][w[b]]
            while t["next"][b] < n and math.dist(xy[b], points[t["next"][b]]) < self.reach:
                t["next"][b] += 1
                t["left"][b] = -1.0
            point = points[t["next"][b]] if t["next"][b] < n else self.goal
            if t["left"][b] < 0:  # a new point: the straight way's actions, times the slack
                t["left"][b] = max(self.slack * math.dist(xy[b], point) / self.step, 5.0)
            t["left"][b] -= 1.0
            if t["left"][b] < 0:  # not reached in time: the options steer again
                t["off"][b] = True
                use[b] = False
                continue
            out[b] = point
        t["following"][:] = use
        t["used"] |= use
        return out

    def _trial_rows(self, choice: np.ndarray) -> np.ndarray:
        """The row of each robot's way for its trial (B,): set at the trial's first step, when
        the start region is the only one entered, from the option chosen there."""
        t = self._trial
        new = t["way"] < 0
        for b in np.flatnonzero(new).tolist():
            k = 0
            if self.start_options > 1:
                entered = np.flatnonzero(choice[b] >= 0)
                if len(entered):
                    t["start"][b] = entered[0]
                    k = int(choice[b, entered[0]])
            t["way"][b] = b * self.start_options + k
        return t["way"]

    # -- learning (the update calls this at a trial's end) --------------------------------
    def learn(
        self,
        row: int,
        pose: np.ndarray,
        sonar: np.ndarray,
        choices: np.ndarray,
        reached: bool,
        first: np.ndarray | None = None,
        goal_searched: bool = False,
    ) -> None:
        """Robot ``row``'s finished trial: odometry poses (T + 1, 3), their scans (T + 1, n)
        over the range, the option chosen in each region (R,) at the trial's end and ``first``
        (R,) the one each region was entered with (the same when none was given up), whether
        it reached the goal, and whether it drove through its believed goal without arriving
        (``goal_searched``: with ``spare_goal_search`` such a trial is no miss of the way, nor
        ends a run of misses). A successful trial shorter than the best so far gives the way
        (with ``start_options``: the way of the start region's option it began with, and of
        the one it ended with, if either's best was longer)."""
        a, t = self.ways, self._trial
        w = int(t["way"][row]) if t["way"][row] >= 0 else row * self.start_options
        steps = len(pose) - 1
        best = int(a["best"][w])
        worse = not reached or steps > best + max(3, 0.1 * best)
        sighted = self.take_past_sight and t["seen"][row] and not t["off"][row] and best < _NONE
        length = self._actions(w) if sighted else 0.0
        if sighted and (not reached or steps > length + max(3, 0.1 * length)):
            a["past_sight"][w] = True  # the options from plain sight did worse than the way
        spared = self.spare_goal_search and goal_searched  # its odometry drifted, not the way
        if t["used"][row] and not spared:  # it took the way: did worse, or as well (misses end)
            a["misses"][w] = a["misses"][w] + 1 if worse else 0
        elif worse and a["misses"][w] >= _MISSES:
            a["misses"][w] = 0  # left to the options, it did worse still: the way again
        first = choices if first is None else first
        given = {w}  # the ways this trial may give
        start = int(t["start"][row])  # set with one way per start option
        if start >= 0:  # the ways of the option it began with and of the one it ended with
            given = {row * self.start_options + int(k) for k in (first[start], choices[start])}
        given = {v for v in given if steps < int(a["best"][v])}
        if not reached or not given:
            return
        way = self._pulled(pose, sonar)
        if len(way) > a["points"].shape[1]:
            return
        for v in sorted(given):
            a["best"][v] = steps
            a["misses"][v] = 0
            a["choices"][v] = choices
            a["first"][v] = first
            a["count"][v] = len(way)
            if way:
                a["points"][v, : len(way)] = np.array(way)
            a["origin"][v] = pose[0, :2]

    def _pulled(self, pose: np.ndarray, sonar: np.ndarray) -> list[np.ndarray]:
        """The via-points from the first pose to the last (where the trial reached the goal, in
        its own odometry), pulled tight backward."""
        echoes = self._echoes(pose, sonar)
        end = len(pose) - 1
        target = pose[end, :2].copy()
        vias: list[np.ndarray] = []
        while True:
            # the pose before is always a way there: the robot drove it (a door post nearer
            # than the clearance hides nothing)
            i = next((i for i in range(end) if self._clear(pose[i, :2], target, echoes)), end - 1)
            if i == 0:
                return vias[::-1]
            target = pose[i, :2].copy()
            vias.append(target)
            end = i

    def _polyline(self, w: int) -> np.ndarray:
        """Way ``w`` (count + 2, 2): where its best trial began, its via-points, the goal."""
        a = self.ways
        n = int(a["count"][w])
        return np.vstack((a["origin"][w][None], a["points"][w, :n], self.goal[None]))

    def _actions(self, w: int) -> float:
        """Way ``w`` in actions: its legs over the step, to the goal's disc."""
        legs = float(np.linalg.norm(np.diff(self._polyline(w), axis=0), axis=1).sum())
        return max(legs - self.goal_radius, 0.0) / self.step

    @property
    def length(self) -> np.ndarray:
        """Each way in actions (B, start_options) (its legs over the step; 0 before a
        success)."""
        best = self.ways["best"]
        length = [self._actions(w) if best[w] < _NONE else 0.0 for w in range(len(best))]
        return np.array(length).reshape(self.best.shape)

    def _ahead(self, w: int, xy: np.ndarray) -> tuple[int, float]:
        """The via-point a robot at ``xy`` steers at when it takes way ``w`` again, and how far
        off the way it is: the end of the way's leg nearest it (index ``count``: the goal)."""
        way = self._polyline(w)
        gaps = [_gap(xy, way[k], way[k + 1]) for k in range(len(way) - 1)]
        ahead = len(gaps) - 1 - int(np.argmin(gaps[::-1]))  # the later leg of two as near
        return ahead, gaps[ahead]

    def _agrees(self, b: int, w: int, xy: np.ndarray, target: np.ndarray) -> bool:
        """Whether robot ``b``'s way (row ``w``) leads where the straight way to ``target``
        does: its next via-point farther from the robot than the body and the clearance (or
        the goal after the last) lies within them of that line; a nearer one lies that near
        every line from the robot and tells nothing. Where the best trial went elsewhere (round
        a wall the scan cannot show), the way is kept."""
        a, t = self.ways, self._trial
        n, k = int(a["count"][w]), int(t["next"][b])
        margin = self.radius + self.clearance
        while k < n and math.dist(xy, a["points"][w, k]) <= margin:
            k += 1  # a point this near lies near every line from the robot: it tells nothing
        point = a["points"][w, k] if k < n else self.goal
        return _gap(point, xy, target) <= margin

    def _goal_edge(self, xy: np.ndarray) -> np.ndarray:
        """Where the straight way from ``xy`` to the goal meets the goal's disc."""
        d = self.goal - xy
        length = math.hypot(*d)
        if length <= self.goal_radius:
            return xy
        return self.goal - d * (self.goal_radius / length)

    def _echoes(self, pose: np.ndarray, sonar: np.ndarray) -> np.ndarray:
        """Every echo of the trial (M, 2), placed from the odometry pose it was read at."""
        angle = pose[:, 2:3] + self._angles
        reach = sonar * self.sonar_range + self.radius
        echoed = sonar < 1.0 - 1e-9
        x = pose[:, 0:1] + reach * np.cos(angle)
        y = pose[:, 1:2] + reach * np.sin(angle)
        return np.stack((x[echoed], y[echoed]), axis=-1)

    def _clear(
        self, start: np.ndarray, target: np.ndarray, echoes: np.ndarray, both_ends: bool = False
    ) -> bool:
        """Whether the straight way from ``start`` to ``target``, within the sonar's range, keeps
        the body and the clearance off every echo (``echoes`` (M, 2)); beside the start, where
        the robot stood, the body alone, and with ``both_ends`` beside the target too (an aim
        is passed or ends the trial there, however near a wall: a goal beside a wall, a
        crossing in a door)."""
        d = target - start
        length = math.hypot(*d)
        if length > self.sonar_range:
            return False
        if length < 1e-9:
            return True
        ex, ey = d / length
        rx, ry = echoes[:, 0] - start[0], echoes[:, 1] - start[1]
        along = rx * ex + ry * ey
        across = np.abs(rx * ey - ry * ex)
        margin = self.radius + self.clearance
        room = np.minimum(along, length - along) if both_ends else along
        need = self.radius + self.clearance * np.minimum(room / margin, 1.0)
        return not bool(((along > 0) & (along < length) & (across < need)).any())


def _gap(p: np.ndarray, start: np.ndarray, end: np.ndarray) -> float:
    """The distance from ``p`` to the segment ``start`` - ``end``."""
    d = end - start
    length2 = float(d @ d)
    f = 0.0 if length2 < 1e-18 else min(max(float((p - start) @ d) / length2, 0.0), 1.0)
    return math.dist(p, start + f * d)
