"""Sub-goal options per region for B controllers: an averaging critic and an epsilon-greedy actor.

Why this exists (docs/LEARNING.md): the literal learner keeps the best single trial, so it locks
onto lucky reflex trials, and its new neurons start from the reflex, which folds into the concave
corner. Here each controller *chooses*, once per region and trial, where the reflex's goal
following points: at the goal or at one of the sub-goals that ``symrl.knowledge.subgoals``
derives from the map's region lines (the door). Obstacle avoidance is untouched. The critic of an
option is the mean, over the trials that chose it, of the return-to-go from the region's first
entry (Monte Carlo, so the concave penalty that lands ~10 actions after the wrong turn is
credited to the turn). Averaging, not comparing single trials, makes the choice robust to noise.

:class:`SubgoalOptions` holds the per-trial choices (decision state it writes when the policy
acts; :meth:`begin_trial` clears it) and reads its ``critic``
(:class:`~symrl.learner.option_critic.OptionCritic`: what is learned across trials, which the
update steps at the end of a trial from :meth:`SubgoalOptions.trial_choices`).
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.grad import no_grad
from symrl.knowledge.planner import shortest_path
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalConfig, SubgoalTable, build_subgoals
from symrl.learner.option_critic import OptionCritic
from symrl.world.geometry import Walls
from symrl.world.worldmap import WorldMap

__all__ = [
    "SubgoalOptions", "subgoal_config", "subgoal_table", "with_planner_waypoints",
    "without_detours",
]  # fmt: skip

# a visit's stages: its first part (at the sub-goal; with a goal lead, at the goal while the
# sub-goal is nearly in line with it), then at the sub-goal, then (the sub-goal reached) at the
# goal; an option with a point to go on to (the table's ``then``) steers at that point between
# reaching its own and the goal
_FIRST_STAGE, _SUBGOAL_STAGE, _GOAL_STAGE, _THEN_STAGE = 0, 1, 2, 3


def subgoal_config(options: object) -> SubgoalConfig:
    """The sub-goal table's settings from an ``OptionsConfig`` section."""
    return SubgoalConfig(
        past=options.subgoal_past,  # type: ignore[attr-defined]
        beyond=(0.0, 0.4) if options.subgoal_on_line else (0.4,),  # type: ignore[attr-defined]
        min_clearance=options.subgoal_min_clearance,  # type: ignore[attr-defined]
    )


class SubgoalOptions(BufferViews):
    """The option learner of B controllers over one map's sub-goal table.

    Buffers: ``points`` (R, K, 2) and ``valid`` (R, K) (the table), and the per-trial
    ``choice`` (B, R) (-1: region not entered yet), ``stage`` (B,) and ``visit`` (B,) (the
    region being visited); ``critic``: the :class:`OptionCritic` it chooses by.
    """

    points: torch.Tensor
    valid: torch.Tensor
    choice: torch.Tensor
    stage: torch.Tensor
    visit: torch.Tensor

    def __init__(
        self,
        world: WorldMap | Knowledge,
        batch: int,
        config: object,
        seeds: list[int],
        table: SubgoalTable | None = None,
        step: float = 0.2,
    ) -> None:
        """``world``: the map (``options.source: map``), or a robot's ``Knowledge`` below it
        with its ``table`` from the region rules (the region limit is then a timeout)."""
        super().__init__()
        mapped = None if isinstance(world, Knowledge) else world
        mapless = mapped is None
        if table is None:
            if mapped is None:
                raise ValueError("SubgoalOptions: without the map, pass the table of the rules")
            table = subgoal_table(mapped, config)
        self.config = config
        self.table = table
        r, k = self.table.valid.shape
        self.labels = self.table.labels
        self.region_names = self.table.region_names
        self.goal = (float(world.goal.x), float(world.goal.y))
        self._goal = np.array(self.goal, dtype=np.float64)
        self._lead = math.radians(float(config.goal_lead_deg))  # type: ignore[attr-defined]
        turn = config.start_turn_deg  # type: ignore[attr-defined]
        self._start_turn = None if turn is None else math.radians(float(turn))
        self.register_buffer("points", self.table.points.to(torch.float64), persistent=False)
        # the point each option goes on to once its own is reached (NaN: the goal); None when
        # no valid option has one (the stages are then those of the paper's options)
        then = self.table.then
        self._then: np.ndarray | None = None
        if then is not None and bool((~torch.isnan(then[..., 0]) & self.table.valid).any()):
            self._then = then.to(torch.float64).numpy().copy()
        self.register_buffer("valid", self.table.valid.clone(), persistent=False)
        slack = config.region_limit  # type: ignore[attr-defined]
        # learned across trials; with the region limit, the options that needed the planner's
        # one (or with the timeout another) to finish their region are not chosen again (the
        # credit of the rescued trial would hide the dead end)
        self.critic = OptionCritic(
            batch, r, k, float(config.epsilon),  # type: ignore[attr-defined]
            float(config.epsilon_decay), str(config.critic),  # type: ignore[attr-defined]
            stalls=slack is not None,
        )  # fmt: skip
        self._zero_turn = np.zeros(batch, dtype=bool)
        self.register_buffer("choice", torch.full((batch, r), -1, dtype=torch.long))
        self.register_buffer("stage", torch.zeros(batch, dtype=torch.long))
        self.register_buffer("visit", torch.full((batch,), -1, dtype=torch.long))
        # each controller's own stream (not the exploration noise's): set k of a batch draws
        # the same numbers as the same seed alone
        self.generators = [torch.Generator().manual_seed(int(s) + 7919) for s in seeds]
        # the region limit: each region's actions (its share of the planner's path, ``step``
        # metres an action, plus the slack) and planner option (-1: none), and per robot and
        # region the actions of the trial in it and whether it has fallen back to that option
        # (reset with every trial, so nothing of it outlives one: not in the state dict)
        self._limit: np.ndarray | None = None
        # without the map: a region's option is given up, for the best one left, after this
        # many actions in the region (no planner to fall back to)
        self._timeout: int | None = int(slack) if mapless and slack is not None else None
        if slack is not None and mapped is not None:
            share = _route_lengths(mapped)
            self._limit = np.array([int(slack) + math.ceil(share.get(name, 0.0) / step)
                                    for name in self.region_names])  # fmt: skip
            self._slack = int(slack)
        usable = self.table.valid.numpy()
        self._planner_option = np.array([next(
            (j for j, label in enumerate(row) if label in ("path", "out") and usable[i, j]), -1)
            for i, row in enumerate(self.labels)], dtype=np.int64)  # fmt: skip
        self._region_steps = np.zeros((batch, r), dtype=np.int64)
        self._fallen_back = np.zeros((batch, r), dtype=bool)
        # a region without a planner option goes on by the planner's path from where the robot
        # is: the turn it steers at (NaN: none) and the region it was planned in
        self._detour = np.full((batch, 2), np.nan)
        self._detour_region = np.full(batch, -1, dtype=np.int64)
        self._world = mapped
        self._walls = (
            Walls(mapped.segments) if mapped is not None and self._limit is not None else None
        )

    # -- acting (called by the policy) ----------------------------------------------------
    def steer(
        self, region: torch.Tensor, odometry: torch.Tensor, greedy: bool
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray]:
        """The signed angle (left positive) from each odometry heading to the point the reflex
        should aim at in ``region``; also the option in force (B,) (the chosen one, or past the
        region limit the region's planner option), whether it was chosen at this step (the
        region's first entry in the trial) (B,) bool, the point (B, 2), and which robots take
        the start turn at this step (B,) bool numpy: a trial's first step with the aim more
        than ``start_turn_deg`` off the heading (the policy turns them straight at the aim)."""
        # numpy on the buffers' memory (a handful of rows: a fraction of the torch dispatches);
        # the norm and atan2 stay torch's, the rest is exact arithmetic in the same order
        a = self.arrays  # the buffers' numpy views
        region_np = region.numpy()
        rows = np.arange(len(region_np))
        choice = a["choice"]
        chosen = choice[rows, region_np]
        entered = chosen < 0
        if entered.any():
            for b in np.flatnonzero(entered).tolist():
                choice[b, region_np[b]] = self._choose(b, int(region_np[b]), greedy)
            chosen = choice[rows, region_np]
        # a new visit of a region starts at its first stage again
        stage, visit = a["stage"], a["visit"]
        stage[region_np != visit] = _FIRST_STAGE
        starting = visit < 0
        visit[:] = region_np
        pose = odometry.numpy().astype(np.float64)
        xy = pose[:, :2]
        if self._timeout is not None:  # without the map: an option timed out gives way
            steps = self._region_steps
            steps[rows, region_np] += 1
            for b in np.flatnonzero(steps[rows, region_np] > self._timeout).tolist():
                here = int(region_np[b])
                self.critic.stall(b, here, int(chosen[b]))
                choice[b, here] = self._choose(b, here, greedy=True)
                steps[b, here], stage[b] = 0, _FIRST_STAGE
            chosen = choice[rows, region_np]
        lost = None
        if self._limit is not None:  # a region past its limit goes on by the planner
            steps, fallen = self._region_steps, self._fallen_back
            steps[rows, region_np] += 1
            planner = self._planner_option[region_np]
            over = steps[rows, region_np] > self._limit[region_np]
            late = over & ~fallen[rows, region_np] & (chosen != planner)
            if late.any():
                fallen[rows[late], region_np[late]] = True
                stage[late] = _FIRST_STAGE
            # no planner option, or the planner option itself chosen and still in the region
            # past its limit (looping round an obstacle it met on the wrong side), or fallen
            # back to it and still in the region the slack later (its point reached, the goal's
            # bearing leads back in: a bay beside the turn): the planner's path from here,
            # turn by turn
            lost = over & ((planner < 0) | (chosen == planner)
                           | (steps[rows, region_np] > self._limit[region_np] + self._slack))
            chosen = np.where(fallen[rows, region_np] & (planner >= 0), planner, chosen)
            self._detour[self._detour_region != region_np] = np.nan
            for b in np.flatnonzero(lost).tolist():
                turn = self._detour[b]
                if np.isnan(turn[0]) or math.dist(turn, xy[b]) < self.config.reach:  # type: ignore[attr-defined]
                    self._detour[b] = self._replan(xy[b])
                    self._detour_region[b] = region_np[b]
        points = a["points"]
        index = region_np * points.shape[1] + chosen
        point = points.reshape(-1, 2)[index]
        distance = torch.linalg.vector_norm(torch.from_numpy(point - xy), dim=-1).numpy()
        reach = self.config.reach  # type: ignore[attr-defined]
        if self._then is None:
            stage[distance < reach] = _GOAL_STAGE
        else:  # the point reached: on to the option's next point if it has one, else the goal
            then = self._then.reshape(-1, 2)[index]
            going_on = stage == _THEN_STAGE
            if going_on.any():
                left = torch.linalg.vector_norm(torch.from_numpy(then - xy), dim=-1).numpy()
                stage[going_on & (left < reach)] = _GOAL_STAGE
            reached = (distance < reach) & ((stage == _FIRST_STAGE) | (stage == _SUBGOAL_STAGE))
            stage[reached] = np.where(np.isnan(then[reached, 0]), _GOAL_STAGE, _THEN_STAGE)
        at_goal = stage == _GOAL_STAGE
        if self._lead > 0:
            first = stage == _FIRST_STAGE
            if first.any():
                g, q = self._goal - xy, point - xy  # to the goal, to the sub-goal
                off = np.abs(np.arctan2(g[:, 0] * q[:, 1] - g[:, 1] * q[:, 0], (g * q).sum(axis=1)))
                stage[first & (off >= self._lead)] = _SUBGOAL_STAGE
                at_goal = at_goal | (stage == _FIRST_STAGE)
        aim = np.where(at_goal[:, None], self._goal, point)
        if self._then is not None:
            aim = np.where((stage == _THEN_STAGE)[:, None], then, aim)
        if lost is not None and lost.any():
            aim = np.where(lost[:, None], self._detour, aim)
        d = aim - xy
        heading = torch.atan2(torch.from_numpy(d[:, 1]), torch.from_numpy(d[:, 0])).numpy()
        angle = np.remainder(heading - pose[:, 2] + math.pi, 2 * math.pi) - math.pi
        start_turn = self._zero_turn
        if self._start_turn is not None:
            start_turn = starting & (np.abs(angle) > self._start_turn)
        return (torch.from_numpy(angle), torch.from_numpy(chosen), torch.from_numpy(entered),
                torch.from_numpy(aim), start_turn)

    def _replan(self, xy: np.ndarray) -> np.ndarray:
        """The first turn of the planner's shortest path from ``xy`` more than ``reach`` away,
        pushed out to 0.45 m from its wall (the goal if the way is straight or unknown)."""
        reach = float(self.config.reach)  # type: ignore[attr-defined]
        start = (float(xy[0]), float(xy[1]))
        assert self._world is not None  # the region limit with the map, the only caller
        for clearance in (None, 0.27):  # pressed against a wall: nearer than the default
            try:
                turns = shortest_path(self._world, start=start, clearance=clearance).waypoints
                break
            except ValueError:
                continue
        else:
            return self._goal.copy()
        assert self._walls is not None  # made with the region limit, the only caller
        for turn in turns[1:-1]:
            if math.dist(turn, start) > reach:
                return np.array(_pushed(self._walls, np.asarray(turn, dtype=np.float64), 0.45))
        return self._goal.copy()

    def _choose(self, b: int, region: int, greedy: bool) -> int:
        """Controller ``b``'s option for ``region`` at its first entry in a trial (on Python
        numbers: a handful of values, read once; the draws are those of the tensor version)."""
        cfg = self.config
        a, learned = self.arrays, self.critic.arrays
        valid = a["valid"][region].tolist()
        if self.critic.stalls:  # a stalled option is as if not offered
            valid = [ok and not stalled for ok, stalled in
                     zip(valid, learned["stalled"][b, region].tolist(), strict=True)]  # fmt: skip
            if not any(valid):
                valid = a["valid"][region].tolist()
        options = [o for o, ok in enumerate(valid) if ok]
        after = int(cfg.greedy_after)  # type: ignore[attr-defined]
        greedy_only = greedy or bool(after and int(learned["trials"][b]) >= after)
        counts = learned["n"][b, region].tolist()
        gen = self.generators[b]
        if not greedy_only:
            untried = [o for o in options if counts[o] == 0]
            if cfg.try_untried and untried:  # type: ignore[attr-defined]
                return untried[0]
            epsilon = float(learned["epsilon"][b])
            if torch.rand((), generator=gen, dtype=torch.float64).item() < epsilon:
                return options[int(torch.randint(len(options), (), generator=gen))]
        q = learned["q"][b, region].tolist()
        tried = [q[o] if counts[o] > 0 and valid[o] else -math.inf for o in range(len(q))]
        best = max(tried)
        if best == -math.inf:
            return options[0]
        return tried.index(best)  # the first of equal values

    @no_grad
    def begin_trial(self, rows: torch.Tensor) -> None:
        """Forget the choices of controllers ``rows`` (their robots start a new trial)."""
        a, r = self.arrays, rows.numpy()
        a["choice"][r] = -1
        a["stage"][r] = _FIRST_STAGE
        a["visit"][r] = -1
        self._region_steps[r], self._fallen_back[r] = 0, False
        self._detour[r], self._detour_region[r] = np.nan, -1

    # -- what the update learns from -----------------------------------------------------
    def trial_choices(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """The trials of controllers ``rows`` as the critic learns from them: the option each
        region was visited with (k, R) (-1: not entered) and, with the region limit, whether
        the region fell back to the planner's option (k, R) (None without it). Copies."""
        choice = self.arrays["choice"][rows].copy()
        fallen = self._fallen_back[rows].copy() if self._limit is not None else None
        return choice, fallen

    def greedy(self, row: int) -> list[int]:
        """The option each region of controller ``row`` would choose greedily (-1: none tried)."""
        critic = self.critic
        q = torch.where((critic.n[row] > 0) & self.valid, critic.q[row], -math.inf)
        best = q.argmax(dim=1)
        return [int(o) if math.isfinite(float(q[r, o])) else -1 for r, o in enumerate(best)]


_TABLES: dict[tuple, SubgoalTable] = {}
"""The sub-goal tables built in this process, by :func:`_table_key` (a few maps at most)."""


def _table_key(world: WorldMap, config: object) -> tuple:
    """Everything a sub-goal table is computed from, exactly: every field of the map (arrays by
    their bytes, shape and dtype; the frozen dataclasses by their repr, whose floats round-trip)
    and the options' table settings."""
    fields: list[object] = []
    for f in dataclasses.fields(world):
        value = getattr(world, f.name)
        items = value if isinstance(value, tuple) else (value,)
        if any(isinstance(v, np.ndarray) for v in items):
            fields.append(tuple((v.shape, v.dtype.str, v.tobytes()) for v in items))
        else:
            fields.append(repr(value))
    planner = bool(config.subgoal_planner)  # type: ignore[attr-defined]
    clearance = float(config.subgoal_min_clearance)  # type: ignore[attr-defined]
    way_out = bool(config.subgoal_way_out)  # type: ignore[attr-defined]
    detour = config.subgoal_detour  # type: ignore[attr-defined]
    detour = None if detour is None else float(detour)
    approach = config.subgoal_approach  # type: ignore[attr-defined]
    approach = None if approach is None else float(approach)
    approach_deg = float(config.subgoal_approach_deg)  # type: ignore[attr-defined]
    first_turn = bool(config.subgoal_planner_first)  # type: ignore[attr-defined]
    return (tuple(fields), subgoal_config(config), planner, clearance, way_out, detour,
            approach, approach_deg, first_turn)  # fmt: skip


def subgoal_table(world: WorldMap, config: object) -> SubgoalTable:
    """The sub-goal table of ``world`` for an ``OptionsConfig`` section: the region lines'
    points, plus with ``subgoal_planner`` the planner's turns (and with ``subgoal_way_out`` a
    dead end's way out), less with ``subgoal_detour`` the detours. A pure function of the map and
    those settings that takes tens of milliseconds (a run's largest setup cost), so it is built
    once per map and settings in a process; the table is shared, and nothing writes into it (the
    options copy its tensors into their buffers)."""
    key = _table_key(world, config)
    table = _TABLES.get(key)
    if table is None:
        table = build_subgoals(world, subgoal_config(config))
        detour = config.subgoal_detour  # type: ignore[attr-defined]
        lengths: dict[tuple[float, float], float] = {}  # the detour test's planner lengths
        if config.subgoal_planner:  # type: ignore[attr-defined]
            table = with_planner_waypoints(
                world,
                table,
                max(config.subgoal_min_clearance, 0.45),  # type: ignore[attr-defined]
                way_out=config.subgoal_way_out,  # type: ignore[attr-defined]
                subgoals=subgoal_config(config),
                first_turn=config.subgoal_planner_first,  # type: ignore[attr-defined]
                # what a region offers ahead: the options the detour test below leaves it
                usable=None if detour is None
                else without_detours(world, table, float(detour), lengths),
            )
        approach = config.subgoal_approach  # type: ignore[attr-defined]
        if approach is not None:
            table = with_approaches(
                world, table, subgoal_config(config), float(approach),
                float(config.subgoal_approach_deg),  # type: ignore[attr-defined]
                max(config.subgoal_min_clearance, 0.0),  # type: ignore[attr-defined]
            )  # fmt: skip
        if detour is not None:
            table = without_detours(world, table, float(detour), lengths)
        if len(_TABLES) >= 16:
            _TABLES.clear()
        _TABLES[key] = table
    return table


def with_planner_waypoints(
    world: WorldMap,
    table: SubgoalTable,
    clearance: float,
    way_out: bool = False,
    subgoals: SubgoalConfig | None = None,
    first_turn: bool = False,
    usable: SubgoalTable | None = None,
) -> SubgoalTable:
    """``table`` plus, per region, one more option: the last turn of the planner's shortest path
    (start to goal) inside the region, pushed out to ``clearance`` from the nearest wall. It is
    the corner a route must round that no region line marks (a thin partition's end).

    A turn belongs to the region the path reaches it in (read 1 mm back along the path): a
    tangent point at a wall corner often lies exactly on a region line through that corner, where
    the strict rules name no region but the default one. A turn where the path passes into
    another region (1 mm on, the region differs) counts for its region only if the path makes no
    turn strictly inside it.

    A region the path crosses straight (no turn in it, not the goal's) whose table offers nothing
    ahead (only the goal and points just past the passage it is entered by: the passage it
    leaves by is open floor, or none) gets the path's next turn, the one after it. A region line
    through a thin wall's end puts that end's turn just past the line: steering at the goal from
    there drives into the wall's far side (``subgoals``: the table's settings, to tell which of
    its passages lie ahead; ``usable``: ``table`` with the options a region cannot use switched
    off, :func:`without_detours`: a region whose points ahead are all detours offers nothing
    ahead either).

    With ``first_turn``, a region in which the path rounds two corners or more (an obstacle on
    open floor, then the region's exit) gets, as its ``path`` option, the first turn with the
    last as the point to go on to (the table's ``then``): the last turn alone sends the reflex
    straight at it, round the obstacle on whichever side it meets first.

    With ``way_out``, a region the path leaves no turn in, whose only option is the goal and
    which does not hold the goal (a dead end off the route: steering at the goal from there
    drives into its back wall for the rest of the trial), gets the first turn of the planner's
    path from its centre (the centroid of its largest piece, or the piece's most open point
    if the centroid is too near a wall), labelled ``out``."""
    plan = shortest_path(world)
    walls = Walls(world.segments)
    inside: dict[str, tuple[float, float]] = {}
    crossing: dict[str, tuple[float, float]] = {}
    first: dict[str, tuple[float, float]] = {}  # each region's first turn strictly inside it
    start = plan.points[0]
    way = np.asarray(plan.waypoints, dtype=np.float64)
    of = world.regions.region_of

    def toward(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        return p + 1e-3 * (q - p) / max(float(np.hypot(*(q - p))), 1e-9)

    def pushed(p: np.ndarray) -> tuple[float, float]:
        return _pushed(walls, p, clearance)

    for i in range(1, len(way) - 1):  # the tangent points; the last one is in the goal disc
        p = way[i]
        if float(np.hypot(*(p - start))) < 0.05:
            continue
        back, on = toward(p, way[i - 1]), toward(p, way[i + 1])
        region = of(float(back[0]), float(back[1]))
        same = region == of(float(on[0]), float(on[1]))
        (inside if same else crossing)[region] = pushed(p)
        if same:
            first.setdefault(region, pushed(p))
    last = crossing | inside
    ahead = usable if usable is not None else table
    last |= _next_turns(world, ahead, way, last, pushed, subgoals or SubgoalConfig())

    outs: dict[str, tuple[float, float]] = {}
    if way_out:
        from shapely.ops import polylabel

        from symrl.knowledge.subgoals import region_pieces

        goal_region = of(float(world.goal.x), float(world.goal.y))
        pieces = region_pieces(world)
        for i, region in enumerate(table.region_names):
            only_goal = table.labels[i][: int(table.valid[i].sum())] == ["goal"]
            if region in last or region == goal_region or not only_goal:
                continue
            piece = max((g for name, g in pieces if name == region),
                        key=lambda g: g.area, default=None)
            if piece is None:
                continue
            turns = None
            for here in (piece.centroid, polylabel(piece, tolerance=0.01)):
                try:
                    turns = shortest_path(world, start=(here.x, here.y)).waypoints
                    break
                except ValueError:  # too near a wall for the planner, or no way on
                    continue
            if turns is None:
                continue
            if len(turns) > 2:  # [from, first turn, ..., end]; a straight way needs none
                outs[region] = pushed(np.asarray(turns[1], dtype=np.float64))
    names = list(table.region_names)
    r, k = table.valid.shape
    points = torch.cat((table.points, torch.zeros(r, 1, 2, dtype=table.points.dtype)), dim=1)
    valid = torch.cat((table.valid, torch.zeros(r, 1, dtype=torch.bool)), dim=1)
    labels = [list(row) for row in table.labels]
    # with ``first_turn``, a region whose path rounds two corners or more steers at the first,
    # then the last: its first turn over 1 m from the last and from where the path enters the
    # region (a corner whose arc a region line cuts is the previous region's)
    entry: dict[str, np.ndarray] = {}
    if first_turn:
        entry = {name: q[0] for name, q in _route_in_regions(world, plan.points).items()}
    two_corners = {region: xy for region, xy in first.items() if first_turn
                   and region in inside and math.dist(xy, inside[region]) > 1.0
                   and math.dist(xy, entry.get(region, xy)) > 1.0}  # fmt: skip
    then = table.then if table.then is not None else torch.full_like(table.points, math.nan)
    then = torch.cat((then, torch.full((r, 1, 2), math.nan, dtype=then.dtype)), dim=1)
    for label, extra in (("path", last), ("out", outs)):  # a region gets one of them at most
        for region, xy in extra.items():
            i = names.index(region)
            n = int(table.valid[i].sum())
            if label == "path" and region in two_corners:
                xy, then_xy = two_corners[region], xy
                then[i, n] = torch.tensor(then_xy, dtype=then.dtype)
            points[i, n] = torch.tensor(xy, dtype=table.points.dtype)
            valid[i, n] = True
            labels[i].append(label)
    # always one column more, valid or not: the table's shape (and a checkpoint's critic) then
    # does not depend on where the path turns, so a controller learned on a world can be run on
    # the world with an obstacle or another start (re-planned: "the planner's turn" again)
    keep = table.then is not None or bool(two_corners)
    return SubgoalTable(table.region_names, points, valid, labels, then if keep else None)


def _pushed(walls: Walls, p: np.ndarray, clearance: float) -> tuple[float, float]:
    """``p`` moved straight away from its nearest wall to ``clearance`` from it."""
    ex, ey, gap = walls.closest(float(p[0]), float(p[1]))  # wall points relative to p
    j = int(np.argmin(ex * ex + ey * ey))
    out = p - np.array((ex[j], ey[j])) / max(gap, 1e-9) * (clearance - gap)
    return (float(out[0]), float(out[1]))


def _next_turns(
    world: WorldMap,
    table: SubgoalTable,
    way: np.ndarray,
    turned: dict[str, tuple[float, float]],
    pushed: Callable[[np.ndarray], tuple[float, float]],
    subgoals: SubgoalConfig,
) -> dict[str, tuple[float, float]]:
    """The regions the path ``way`` (start, turns, end) crosses straight, off ``turned`` and the
    goal's region, whose table has no option ahead: each with the path's next turn, pushed."""
    from symrl.knowledge.subgoals import find_passages, passage_labels, routes

    of = world.regions.region_of
    goal_region = of(float(world.goal.x), float(world.goal.y))
    crossed: dict[str, tuple[float, float]] = {}
    for i in range(len(way) - 2):  # the last leg ends in the goal disc: no turn after it
        a, b = way[i], way[i + 1]
        n = max(2, int(math.ceil(float(np.hypot(*(b - a))) / 0.05)))
        for t in np.arange(1, n) / n:  # the leg's inside, every 5 cm
            region = of(*(float(v) for v in a + t * (b - a)))
            if region not in turned and region != goal_region and region not in crossed:
                crossed[region] = pushed(b)
    if not crossed:
        return {}
    passages = find_passages(world, subgoals)
    ahead_of, _ = routes(world, passages)
    names = passage_labels(passages)
    out = {}
    for region, xy in crossed.items():
        i = table.region_names.index(region)
        ahead = {names[k] for k in ahead_of[region]}
        options = [label for label, ok in zip(table.labels[i], table.valid[i].tolist(),
                                              strict=False) if ok]  # fmt: skip
        if not any(label.split("@")[0] in ahead for label in options):
            out[region] = xy
    return out


class _Route(NamedTuple):
    """The planner's start-to-goal path of one map, by region: its points and its length in
    metres."""

    along: dict[str, list[np.ndarray]]
    lengths: dict[str, float]


_ROUTES: dict[int, tuple[weakref.ref, _Route]] = {}
"""The start-to-goal route of the maps seen in this process (by the map object's id; the weak
reference tells a reused id from the same map): a study's final per-set policies ask for it
once each (6 ms a policy on the paper's map)."""


def _route(world: WorldMap) -> _Route:
    """The start-to-goal route of ``world``, planned once and shared: callers only read it."""
    known = _ROUTES.get(id(world))
    if known is not None and known[0]() is world:
        return known[1]
    if len(_ROUTES) >= 16:
        _ROUTES.clear()
    points = shortest_path(world).points
    route = _Route(_along(world, points), _lengths(world, points))
    _ROUTES[id(world)] = (weakref.ref(world), route)
    return route


def _route_in_regions(
    world: WorldMap, points: np.ndarray | None = None
) -> dict[str, list[np.ndarray]]:
    """The planner's shortest path (start to goal; ``points``: its dense points if the caller
    has planned it) in each region it passes through, a point every 0.1 m or closer, in order
    (a region's first point is where the path enters it). Without ``points`` the answer is
    remembered and shared: callers only read it."""
    return _route(world).along if points is None else _along(world, points)


def _route_lengths(world: WorldMap) -> dict[str, float]:
    """The planner's shortest path (start to goal): its length in metres in each region it
    passes through (remembered and shared: callers only read it)."""
    return _route(world).lengths


def _along(world: WorldMap, points: np.ndarray) -> dict[str, list[np.ndarray]]:
    """:func:`_route_in_regions` of the path through ``points``."""
    along: dict[str, list[np.ndarray]] = {}
    pts = np.asarray(points, dtype=np.float64)
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / 0.1)))
        for t in np.arange(n) / n:
            q = a + t * (b - a)
            along.setdefault(world.regions.region_of(float(q[0]), float(q[1])), []).append(q)
    return along


def _lengths(world: WorldMap, points: np.ndarray) -> dict[str, float]:
    """The length of the path through ``points`` in each region: each piece of it (1 cm or
    shorter) counted in the region of its middle. Arc length, not a count of the points: on
    the planner's arcs around corners the points lie millimetres apart."""
    pts = np.asarray(points, dtype=np.float64)
    a, b = pts[:-1], pts[1:]
    n = np.maximum(1, np.ceil(np.hypot(*(b - a).T) / 0.01)).astype(np.int64)
    leg = np.repeat(np.arange(len(a)), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n) + 0.5) / n[leg]
    mid = a[leg] + t[:, None] * (b - a)[leg]
    piece = np.hypot(*(b - a).T)[leg] / n[leg]
    lengths: dict[str, float] = {}
    for region, d in zip(world.regions.regions_of(mid[:, 0], mid[:, 1]), piece.tolist(),
                         strict=True):  # fmt: skip
        lengths[region] = lengths.get(region, 0.0) + d
    return lengths


def with_approaches(
    world: WorldMap,
    table: SubgoalTable,
    subgoals: SubgoalConfig,
    distance: float,
    min_angle_deg: float,
    min_clearance: float,
) -> SubgoalTable:
    """``table`` plus approach options (``OptionsConfig.subgoal_approach``): per region, one per
    passage of the table ahead of it whose approach point (``distance`` metres before the
    passage's centre on its normal) lies in the region, in the free area and at least
    ``min_clearance`` from the walls. Its ``then`` is the passage's centre 0.4 m past the line.
    Valid only where the planner's path enters the region and the straight line from that
    entry to the passage's centre runs more than ``min_angle_deg`` off the passage's normal (a
    door in a side wall); the columns exist either way, so the table's shape depends on the
    map's passages only, not on the start or the route."""
    from symrl.knowledge.subgoals import _clearance, find_passages, passage_labels, routes

    passages = find_passages(world, subgoals)
    ahead_of, _ = routes(world, passages)
    names = passage_labels(passages)
    along = _route_in_regions(world)
    cos_max = math.cos(math.radians(min_angle_deg))
    Approach = tuple[tuple[float, float], tuple[float, float], str, bool]  # point, then, label, on
    extra: list[list[Approach]] = []
    for region in table.region_names:
        found: list[Approach] = []
        for k in sorted(ahead_of[region]):
            p = passages[k]
            if p.width > subgoals.max_width or p.width / 2 < subgoals.clearance:
                continue
            centre = (p.lo + p.hi) / 2
            a = p.point(centre, -distance)
            if world.regions.region_of(*a) != region or not bool(world.in_free_area(*a)):
                continue
            if _clearance(world, a) < min_clearance:
                continue
            if any(math.dist(a, q) < distance / 2 for q, *_ in found):
                continue  # a door's two faces: one approach for it
            on = False
            if region in along:
                to = np.asarray(p.point(centre, 0.0)) - along[region][0]
                normal = np.zeros(2)
                normal[p.axis] = p.normal
                on = float(to @ normal) < cos_max * max(float(np.hypot(*to)), 1e-9)
            found.append((a, p.point(centre, 0.4), f"{names[k]}@approach", on))
        extra.append(found)
    width = max((len(f) for f in extra), default=0)
    if width == 0:
        return table
    r, k = table.valid.shape
    n = table.valid.sum(dim=1)
    points = torch.cat((table.points, torch.zeros(r, width, 2, dtype=table.points.dtype)), 1)
    valid = torch.cat((table.valid, torch.zeros(r, width, dtype=torch.bool)), 1)
    then = table.then if table.then is not None else torch.full_like(table.points, math.nan)
    then = torch.cat((then, torch.full((r, width, 2), math.nan, dtype=then.dtype)), 1)
    labels = [list(row) for row in table.labels]
    for i, found in enumerate(extra):
        for j, (a, past, label, on) in enumerate(found):
            # after the region's own options, in its first free columns (the rest pad)
            col = int(n[i]) + j
            points[i, col] = torch.tensor(a, dtype=points.dtype)
            then[i, col] = torch.tensor(past, dtype=then.dtype)
            valid[i, col] = on
            labels[i].insert(col, label)
    return SubgoalTable(table.region_names, points, valid, labels, then)


def without_detours(
    world: WorldMap,
    table: SubgoalTable,
    margin: float,
    lengths: dict[tuple[float, float], float] | None = None,
) -> SubgoalTable:
    """``table`` with the sub-goals a region's best route cannot use switched off (``valid``
    False; the table keeps its shape). For each region the planner's shortest path (start to
    goal) passes through, with ``e`` the path's first point in the region (the start in the
    start's region), a sub-goal ``p`` is dropped when the reflex cannot steer straight at it
    from any point of the path in the region (every such segment crosses a wall: the reflex
    would follow the bearing into the wall or a dead end; a segment that only grazes a corner
    is left to the obstacle avoidance), or
    when the route through it, ``|e p|`` plus the planner's length from ``p`` to the goal, is
    more than ``margin`` metres longer than the planner's length from ``e`` (a point nearer a
    wall than the planner's clearance has no length and is judged by the first test only, and
    so are all points of a region whose entry is).
    The goal (the paper's reflex) and the planner's own turns (``path``) are always kept, and
    so is every option of a region the path does not enter. ``lengths``: the planner's length
    from each point judged, kept between calls on the same map (a planner call each)."""
    walls = Walls(world.segments)

    def straight(a: np.ndarray, b: np.ndarray) -> bool:  # crosses no wall (1 cm: not a graze)
        mid = 0.5 * (a + b)
        inside = bool(world.contains_xy(mid[0], mid[1]))
        return inside and not walls.swept_disc_contact(a[0], a[1], b[0], b[1], 0.01)

    along = _route_in_regions(world)
    entry = {region: points[0] for region, points in along.items()}
    valid = table.valid.clone()
    lengths = {} if lengths is None else lengths

    def to_goal(xy: np.ndarray) -> float:
        key = (round(float(xy[0]), 6), round(float(xy[1]), 6))
        if key not in lengths:
            try:
                lengths[key] = shortest_path(world, start=key).length
            except ValueError:  # nearer a wall than the planner's clearance: length unknown
                lengths[key] = -math.inf
        return lengths[key]

    for i, region in enumerate(table.region_names):
        e = entry.get(region)
        if e is None:
            continue
        best = to_goal(e)
        for k, label in enumerate(table.labels[i]):
            if not bool(valid[i, k]) or label in ("goal", "path"):
                continue
            p = table.points[i, k].to(torch.float64).numpy()
            longer = float(np.hypot(*(p - e))) + to_goal(p) > best + margin
            if (math.isfinite(best) and longer) or not any(straight(q, p) for q in along[region]):
                valid[i, k] = False
    return SubgoalTable(table.region_names, table.points, valid, table.labels, table.then)
