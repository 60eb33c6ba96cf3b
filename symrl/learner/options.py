"""Sub-goal options per region for B controllers: an averaging critic and an epsilon-greedy actor.

Why this exists (docs/journal/learning.md): the literal learner keeps the best single trial, so
it locks onto lucky reflex trials, and its new neurons start from the reflex, which folds into the
concave corner. Here each controller *chooses*, once per region and trial, where the reflex's goal
following points: at the goal or at a point of a border or passage toward the goal's region
(``symrl.knowledge.borders``), and told the map also the *route*: a point ahead on the shortest
path re-planned from where the robot believes it is (``symrl.knowledge.route``). Obstacle
avoidance is untouched. The critic of an option is the mean, over the trials that chose it, of
the return-to-go from the region's first entry (Monte Carlo, so the concave penalty that lands
~10 actions after the wrong turn is credited to the turn). Averaging, not comparing single
trials, makes the choice robust to noise. An option that has spent ``region_limit`` actions in a
region is given up for the best one left (a trap such as the concave corner), except the route,
which is re-planned instead.

:class:`SubgoalOptions` holds the per-trial choices (decision state it writes when the policy
acts; :meth:`begin_trial` clears it) and reads its ``critic``
(:class:`~symrl.learner.option_critic.OptionCritic`: what is learned across trials, which the
update steps at the end of a trial from :meth:`SubgoalOptions.trial_choices`).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from symrl.buffers import BufferViews
from symrl.grad import no_grad
from symrl.knowledge.borders import border_options, goal_region, hops_from
from symrl.knowledge.option_sources import ROUTE, option_table
from symrl.knowledge.route import Route
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable
from symrl.learner.config import CrossingsConfig, OptionCriticConfig, OptionsConfig
from symrl.learner.crossings import Crossing, CrossingMap
from symrl.learner.goal_scans import GoalScans
from symrl.learner.option_critic import OptionCritic
from symrl.learner.remembered_way import RememberedWay
from symrl.learner.wall_follow import WallFollow
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import WorldMap

__all__ = ["SubgoalOptions"]

# a visit's stages: its first part (at the sub-goal; with a goal lead, at the goal while the
# sub-goal is nearly in line with it), then at the sub-goal, then (the sub-goal reached) at the
# goal
_FIRST_STAGE, _SUBGOAL_STAGE, _GOAL_STAGE = 0, 1, 2


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
        knowledge: Knowledge | WorldMap,
        batch: int,
        config: OptionsConfig,
        seeds: list[int],
        table: SubgoalTable | None = None,
        explore: OptionCriticConfig | None = None,
        crossings: CrossingsConfig | None = None,
        robot: RobotConfig | None = None,
        max_actions: int = 200,
    ) -> None:
        """``knowledge``: what the robot is told (a ``WorldMap``: told the whole map);
        ``table``: its option table if already built (``option_table``); ``explore``: the
        option critic's settings (defaults without); ``crossings``: learn where each border
        can be crossed (``options.source: rules``), for a robot ``robot`` whose trials last at
        most ``max_actions`` actions."""
        super().__init__()
        if not isinstance(knowledge, Knowledge):
            knowledge = Knowledge.told(knowledge, "map")
        self.config = config
        explore = explore if explore is not None else OptionCriticConfig()
        self.explore = explore
        self.crossings: CrossingMap | None = None
        self.remembered_way: RememberedWay | None = None
        if crossings is not None and crossings.enabled:
            self._init_crossings(knowledge, batch, crossings, robot or RobotConfig(), max_actions)
        elif table is None:
            table = option_table(knowledge, config.source)
        self.table = self._border_options.table if self.crossings is not None else table
        assert self.table is not None
        r, k = self.table.valid.shape
        self.labels = self.table.labels
        self.region_names = self.table.region_names
        self.goal = (float(knowledge.goal.x), float(knowledge.goal.y))
        self._goal = np.array(self.goal, dtype=np.float64)
        self._lead = math.radians(config.goal_lead_deg)
        turn = config.start_turn_deg
        self._start_turn = None if turn is None else math.radians(turn)
        self.register_buffer("points", self.table.points.to(torch.float64), persistent=False)
        self.register_buffer("valid", self.table.valid.clone(), persistent=False)
        # the route option's column of each region (-1: none) and its planner (map rung only)
        self._route_option = np.array(
            [row.index(ROUTE) if ROUTE in row else -1 for row in self.labels], dtype=np.int64
        )
        self.route = (
            Route(knowledge.geometry("the route option"), batch, config.ahead, config.reach)
            if (self._route_option >= 0).any()
            else None
        )
        slack = config.region_limit
        self._bounds_tries = explore.try_if_shorter and self.crossings is None
        # learned across trials; with the region limit, an option given up is not chosen again
        self.critic = OptionCritic(
            batch,
            r,
            k,
            explore.epsilon,
            explore.epsilon_decay,
            explore.critic,
            explore.credit,
            stalls=slack is not None and self.crossings is None,
            shortest=self._bounds_tries,
        )
        # the actions of the trial so far, and each option's way on from its point (the bound)
        self._trial_steps = np.zeros(batch, dtype=np.int64)
        self._planned: np.ndarray | None = None
        self._to_goal = self._ways_on(knowledge) if self._bounds_tries else None
        self._zero_turn = np.zeros(batch, dtype=bool)
        body = robot or RobotConfig()
        self.goal_scans = (
            GoalScans(
                batch,
                goal=self.goal,
                goal_radius=float(knowledge.goal.radius),
                robot=body,
                passing_by=config.goal_scans_passing_by,
                within_drift=config.goal_scans_within_drift,
            )
            if config.goal_scans
            else None
        )
        self.wall_follow = WallFollow(batch, body) if config.wall_follow else None
        self.register_buffer("choice", torch.full((batch, r), -1, dtype=torch.long))
        self._first = np.full((batch, r), -1, dtype=np.int64)  # each region's first choice
        self.register_buffer("stage", torch.zeros(batch, dtype=torch.long))
        self.register_buffer("visit", torch.full((batch,), -1, dtype=torch.long))
        # each controller's own stream (not the exploration noise's): set k of a batch draws
        # the same numbers as the same seed alone
        self.generators = [torch.Generator().manual_seed(int(s) + 7919) for s in seeds]
        # the timeout: an option is given up for the best one left after this many actions of
        # a trial in its region (reset with every trial: not in the state dict); with
        # ``region_limit_scale``, more for an option whose aim lies farther off when chosen
        self._timeout = slack
        self._region_steps = np.zeros((batch, r), dtype=np.int64)
        self._limit_scale = config.region_limit_scale
        self._step_length = float((robot or RobotConfig()).step)
        self._limit = np.full((batch, r), math.inf if slack is None else float(slack))

    def _ways_on(self, knowledge: Knowledge) -> np.ndarray:
        """(R, K) the metres from each option's point to the goal disc at the least: the
        straight way (the route's: 0); told the map, :meth:`_could_be_shorter` replaces it with
        the planned way where the straight one cannot tell."""
        table = self.table
        assert table is not None
        points = table.points.numpy().astype(np.float64)
        goal = knowledge.goal
        straight = np.hypot(points[..., 0] - goal.x, points[..., 1] - goal.y) - goal.radius
        ways = np.maximum(straight, 0.0)
        ways[~table.valid.numpy()] = 0.0
        on_route = self._route_option >= 0
        ways[np.flatnonzero(on_route), self._route_option[on_route]] = 0.0
        # planned once each, and only when asked (a plan on a building takes up to seconds)
        self._planned = np.zeros(ways.shape, dtype=bool) if self.route is not None else None
        return ways

    def _could_be_shorter(self, b: int, region: int, option: int, xy: np.ndarray) -> bool:
        """Whether robot ``b`` at ``xy`` trying ``option`` of ``region`` could still finish
        the trial in fewer actions than its shortest trial to the goal so far."""
        assert self._to_goal is not None
        if option == self._route_option[region]:
            return True
        shortest = self.critic.shortest_trial(b)
        point = self.arrays["points"][region, option]
        to_point = math.hypot(point[0] - xy[0], point[1] - xy[1])

        def bound() -> float:
            assert self._to_goal is not None
            way = to_point + self._to_goal[region, option]
            return self._trial_steps[b] + way / self._step_length

        planned = self._planned
        if bound() < shortest and planned is not None and not planned[region, option]:
            assert self.route is not None
            length = self.route.plan_from(np.asarray(point, dtype=np.float64))
            if length is not None:
                self._to_goal[region, option] = max(self._to_goal[region, option], length)
            planned[region, option] = True
        return bound() < shortest

    def _init_crossings(
        self,
        knowledge: Knowledge,
        batch: int,
        config: CrossingsConfig,
        robot: RobotConfig,
        max_actions: int,
    ) -> None:
        """Every border of a region is an option; where each can be crossed is learned."""
        opts = border_options(knowledge.regions, knowledge.goal)
        self._border_options = opts
        k = opts.table.valid.shape[1]
        self._border = np.full((len(opts.border), k), -1, dtype=np.int64)
        self._side = np.zeros((len(opts.border), k), dtype=np.float64)
        for r, (ids, signs) in enumerate(zip(opts.border, opts.side, strict=True)):
            self._border[r, : len(ids)] = ids
            self._side[r, : len(signs)] = signs
        start = knowledge.start
        self.crossings = CrossingMap(
            opts.borders,
            batch,
            radius=robot.radius,
            close_distance=robot.close_distance,
            sonar_range=robot.sonar_range,
            n_sensors=robot.n_sensors,
            origin=(float(start.x), float(start.y)),
            reach=max_actions * robot.step + robot.sonar_range + robot.radius,
            resolution=config.resolution,
            dead_ends=config.dead_ends,
            step=robot.step,
            translation_noise=robot.translation_noise,
            rotation_noise=math.radians(robot.rotation_noise_deg),
            region_names=knowledge.regions.names,
        )
        self._beyond = 0.4
        self._start_xy = np.array([float(start.x), float(start.y)])
        names = list(knowledge.regions.names)
        self._region_of = {n: i for i, n in enumerate(names)}
        self._target = names.index(goal_region(knowledge.regions, knowledge.goal))
        if self.config.remembered_way:
            self.remembered_way = RememberedWay(
                batch,
                len(names),
                goal=(float(knowledge.goal.x), float(knowledge.goal.y)),
                goal_radius=float(knowledge.goal.radius),
                radius=robot.radius,
                clearance=robot.close_distance,
                sonar_range=robot.sonar_range,
                n_sensors=robot.n_sensors,
                step=robot.step,
                max_points=max_actions,
                take_past_sight=self.config.way_past_sight,
                spare_goal_search=self.config.way_spares_goal_search,
                start_options=k if self.config.way_per_start_option else 1,
            )
        j = len(opts.borders)
        # per robot: the borders found blocked, the region graph's hops without them
        self._blocked = np.zeros((batch, j), dtype=bool)
        # the borders without which the rules' graph has no way to the goal's region from one
        # side: their stretches seen only behind other walls are still crossings (the last
        # taken), so a room the robot starts in, which hides the line beyond its own walls, does
        # not lose its only border for good (that wall may be passed round; one on the line not)
        target = names[self._target]
        self._bridges = np.zeros(j, dtype=bool)
        for i, border in enumerate(opts.borders):
            hops = hops_from(target, [x for k, x in enumerate(opts.borders) if k != i])
            self._bridges[i] = border.low not in hops or border.high not in hops
        self._hops = np.zeros((batch, len(names)))
        for b in range(batch):
            self._rehop(b)
        shape = (batch, len(names), k)
        self._lining_up = np.zeros(batch, dtype=bool)  # aiming in front of a crossing
        # per trial: the options given up (the critic learns what they cost from the returns
        # of every choice, so none is banned for good), and who chose anew at this step
        self._trial_stalled = np.zeros(shape, dtype=bool)
        self._rechose = np.zeros(batch, dtype=bool)

    def _rehop(self, b: int) -> None:
        """Robot ``b``'s hops from the goal's region over the borders it has not found blocked."""
        opts = self._border_options
        open_borders = [
            x for x, shut in zip(opts.borders, self._blocked[b], strict=True) if not shut
        ]
        names = opts.table.region_names
        hops = hops_from(names[self._target], open_borders)
        self._hops[b] = [hops.get(n, math.inf) for n in names]

    def _offered(self, b: int, region: int, valid: list[bool], stalled: list[bool]) -> list[bool]:
        """Which of ``region``'s options robot ``b`` is offered: the goal and the borders it has
        not found blocked that lead no farther from the goal's region, where one of them has
        not stalled; else every border not found blocked that has not stalled (the ways back
        out of a dead end); else the goal and every border not found blocked."""
        names = self._border_options.table.region_names
        mine = self._hops[b, region]
        ahead, open_ = [], []
        for k, j in enumerate(self._border[region].tolist()):
            if not valid[k] or (j >= 0 and self._blocked[b, j]):
                ahead.append(False)
                open_.append(False)
                continue
            open_.append(True)
            if j < 0:
                ahead.append(True)
                continue
            border = self._border_options.borders[j]
            other = border.high if names[region] == border.low else border.low
            theirs = self._hops[b, self._region_of[other]]
            ahead.append(not math.isfinite(mine) or theirs <= mine)
        back = [ok and j >= 0 for ok, j in zip(open_, self._border[region].tolist(), strict=True)]
        for wanted in (ahead, back):
            fresh = [ok and not s for ok, s in zip(wanted, stalled, strict=True)]
            if any(fresh):
                return fresh
        return open_

    def _stall(self, b: int, region: int, option: int) -> None:
        """Controller ``b`` gives ``option`` up in ``region`` (for the trial with crossings,
        for good without); with crossings, the goal in the goal's region is never given up."""
        if self.crossings is not None:
            # in the goal's region the goal is the way on: the reflex finds its way round
            if not (region == self._target and self._border[region, option] < 0):
                self._trial_stalled[b, region, option] = True
            self._rechose[b] = True
        else:
            self.critic.stall(b, region, option)

    @property
    def bridges(self) -> np.ndarray:
        """The borders (J,) bool without which the rules' region graph has no way to the
        goal's region from one side (their stretches seen only behind walls stay crossings); a
        copy, read by the trial records."""
        return self._bridges.copy()

    def _crossing(self, b: int, border: int, xy: np.ndarray) -> Crossing | None:
        """Robot ``b``'s crossing of ``border`` from ``xy`` (None: found blocked); a bridge of
        the rules' graph counts its stretches seen only behind other walls too."""
        assert self.crossings is not None
        hidden_too = bool(self._bridges[border])
        return self.crossings.crossing(b, border, xy, self.goal, hidden_too=hidden_too)

    def _cross_point(self, b: int, region: int, option: int, xy: np.ndarray) -> np.ndarray | None:
        """Robot ``b``'s aim for a border option: past the line at the crossing it believes
        best (or in front of it, to line up with it); None when it found the border blocked
        (:meth:`_crossing`)."""
        assert self.crossings is not None
        j = int(self._border[region, option])
        found = self._crossing(b, j, xy)
        if found is None:
            return None
        t, first, last = found
        border = self._border_options.borders[j]
        side = self._side[region, option]
        x, y = border.at(t, side * self._beyond)
        # straight at the point past the line where that way crosses the stretch with a body
        # radius to spare; else first to the point in front of the crossing, to line up with it
        crossings = self.crossings
        t0 = crossings.lo[j] + first * crossings.resolution + crossings.radius
        t1 = crossings.lo[j] + (last + 1) * crossings.resolution - crossings.radius
        here = xy[border.axis] - border.intercept  # signed distance to the line
        ahead = -side * here  # how far before the line, on the robot's side
        if ahead > 0 and t0 <= t1:
            along = xy[1 - border.axis]
            hit = along + (t - along) * ahead / (ahead + self._beyond)
            if not t0 <= hit <= t1:
                x, y = border.at(t, -side * min(crossings.inset, ahead))
                self._lining_up[b] = True
        return np.array([x, y])

    def _cross(
        self,
        region: np.ndarray,
        chosen: np.ndarray,
        stage: np.ndarray,
        xy: np.ndarray,
        point: np.ndarray,
        greedy: bool,
    ) -> None:
        """Aim the robots on a border option at their crossing (re-choosing where a border turns
        out blocked)."""
        crossings = self.crossings
        assert crossings is not None
        choice = self.arrays["choice"]
        self._lining_up[:] = False
        for b in range(len(region)):
            r = int(region[b])
            while stage[b] != _GOAL_STAGE and self._border[r, chosen[b]] >= 0:
                found = self._cross_point(b, r, int(chosen[b]), xy[b])
                if found is not None:
                    point[b] = found
                    break
                self._blocked[b, self._border[r, chosen[b]]] = True
                self._rehop(b)
                self._stall(b, r, int(chosen[b]))
                chosen[b] = choice[b, r] = self._choose(b, r, greedy=True)
                stage[b] = _FIRST_STAGE

    # -- acting (called by the policy) ----------------------------------------------------
    def steer(
        self,
        region: torch.Tensor,
        odometry: torch.Tensor,
        greedy: bool,
        sonar: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray]:
        """The signed angle (left positive) from each odometry heading to the point the reflex
        should aim at in ``region``; also the option in force (B,), whether it was chosen at
        this step (the region's first entry in the trial) (B,) bool, the point (B, 2), and which
        robots take the start turn at this step (B,) bool numpy: the aim more than
        ``start_turn_deg`` off the heading at a trial's first step, or at any step on the route
        (the policy turns them straight at the aim)."""
        # numpy on the buffers' memory (a handful of rows: a fraction of the torch dispatches);
        # the norm and atan2 stay torch's, the rest is exact arithmetic in the same order
        a = self.arrays  # the buffers' numpy views
        region_np = region.numpy()
        rows = np.arange(len(region_np))
        if self.crossings is not None:
            self._rechose[:] = False
        choice = a["choice"]
        chosen = choice[rows, region_np]
        entered = chosen < 0
        pose = odometry.numpy().astype(np.float64)
        xy = pose[:, :2]
        if entered.any():
            for b in np.flatnonzero(entered).tolist():
                choice[b, region_np[b]] = self._choose(b, int(region_np[b]), greedy, xy[b])
                self._first[b, region_np[b]] = choice[b, region_np[b]]
            chosen = choice[rows, region_np]
        # a new visit of a region starts at its first stage again
        stage, visit = a["stage"], a["visit"]
        stage[region_np != visit] = _FIRST_STAGE
        starting = visit < 0
        visit[:] = region_np
        self._trial_steps += 1
        on_route = chosen == self._route_option[region_np]
        late = self._zero_turn
        if self._timeout is not None:  # an option timed out gives way (the route re-plans)
            steps = self._region_steps
            steps[rows, region_np] += 1
            late = (steps[rows, region_np] > self._limit[rows, region_np]) & ~on_route
            if self.remembered_way is not None:  # the way has its own timeout
                late &= ~self.remembered_way.following
            for b in np.flatnonzero(late).tolist():
                here = int(region_np[b])
                self._stall(b, here, int(chosen[b]))
                choice[b, here] = self._choose(b, here, greedy=True)
                steps[b, here], stage[b] = 0, _FIRST_STAGE
            chosen = choice[rows, region_np]
            on_route = chosen == self._route_option[region_np]
        points = a["points"]
        point = points.reshape(-1, 2)[region_np * points.shape[1] + chosen]
        if self.crossings is not None:
            chosen = chosen.copy()
            self._cross(region_np, chosen, stage, xy, point, greedy)
            on_route = chosen == self._route_option[region_np]
        if self.route is not None and on_route.any():
            point[on_route] = self.route.aim(np.flatnonzero(on_route), xy[on_route])
        distance = torch.linalg.vector_norm(torch.from_numpy(point - xy), dim=-1).numpy()
        if self._limit_scale is not None and self._timeout is not None:
            chose = entered | late if self.crossings is None else entered | self._rechose
            self._set_limit(rows[chose], region_np[chose], distance[chose])
        reached = (distance < self.config.reach) & ~on_route
        if self.crossings is not None:
            reached &= ~self._lining_up  # in front of a crossing is not past it
        stage[reached] = _GOAL_STAGE
        at_goal = stage == _GOAL_STAGE
        if self._lead > 0:
            first = stage == _FIRST_STAGE
            if first.any():
                g, q = self._goal - xy, point - xy  # to the goal, to the sub-goal
                off = np.abs(np.arctan2(g[:, 0] * q[:, 1] - g[:, 1] * q[:, 0], (g * q).sum(axis=1)))
                stage[first & (off >= self._lead)] = _SUBGOAL_STAGE
                at_goal = at_goal | (stage == _FIRST_STAGE)
        aim = np.where(at_goal[:, None], self._goal, point)
        scan = None
        if sonar is not None and (
            self.remembered_way is not None
            or self.goal_scans is not None
            or self.wall_follow is not None
        ):
            scan = sonar.numpy().astype(np.float64)
        if self.remembered_way is not None:
            aim = self.remembered_way.aim(a["choice"], pose, aim, scan)
        if self.goal_scans is not None:
            aim = self.goal_scans.aim(pose, aim, scan)
        if self.wall_follow is not None:
            aim = self.wall_follow.aim(pose, aim, scan)
        d = aim - xy
        heading = torch.atan2(torch.from_numpy(d[:, 1]), torch.from_numpy(d[:, 0])).numpy()
        angle = np.remainder(heading - pose[:, 2] + math.pi, 2 * math.pi) - math.pi
        start_turn = self._zero_turn
        if self._start_turn is not None:
            start_turn = (starting | on_route) & (np.abs(angle) > self._start_turn)
        if self.crossings is not None:  # every choice is credited with what followed it
            entered = entered | self._rechose
        return (
            torch.from_numpy(angle),
            torch.from_numpy(chosen),
            torch.from_numpy(entered),
            torch.from_numpy(aim),
            start_turn,
        )

    def _set_limit(self, rows: np.ndarray, region: np.ndarray, distance: np.ndarray) -> None:
        """The timeout of the options just chosen by robots ``rows`` in ``region``: the actions
        the straight way to their aim (``distance`` m off) takes, times ``region_limit_scale``,
        and at least ``region_limit`` (a constant limit gives up an option aimed across a large
        region before the robot can get there)."""
        assert self._limit_scale is not None and self._timeout is not None
        need = self._limit_scale * distance / self._step_length
        self._limit[rows, region] = np.maximum(float(self._timeout), need)

    def _choose(self, b: int, region: int, greedy: bool, xy: np.ndarray | None = None) -> int:
        """Controller ``b``'s option for ``region`` at its first entry in a trial, its robot at
        ``xy`` (on Python numbers: a handful of values, read once; the draws are those of the
        tensor version)."""
        explore = self.explore
        a, learned = self.arrays, self.critic.arrays
        valid = a["valid"][region].tolist()
        if self.crossings is not None:
            valid = self._offered(b, region, valid, self._trial_stalled[b, region].tolist())
        elif self.critic.stalls:  # a stalled option is as if not offered
            valid = [
                ok and not stalled
                for ok, stalled in zip(valid, learned["stalled"][b, region].tolist(), strict=True)
            ]
            if not any(valid):
                valid = a["valid"][region].tolist()
        options = [o for o, ok in enumerate(valid) if ok]
        after = explore.greedy_after
        greedy_only = greedy or bool(after and int(learned["trials"][b]) >= after)
        counts = learned["n"][b, region].tolist()
        gen = self.generators[b]
        if not greedy_only:
            untried = [o for o in options if counts[o] == 0]
            if self._to_goal is not None and xy is not None:
                untried = [o for o in untried if self._could_be_shorter(b, region, o, xy)]
            if explore.try_untried and untried:
                return untried[0]
            epsilon = float(learned["epsilon"][b])
            if torch.rand((), generator=gen, dtype=torch.float64).item() < epsilon:
                drawn = options  # bounded as the untried are (the route's option always passes)
                if self._to_goal is not None and xy is not None:
                    drawn = [o for o in options if self._could_be_shorter(b, region, o, xy)]
                    drawn = drawn or options
                return drawn[int(torch.randint(len(drawn), (), generator=gen))]
        q = learned["q"][b, region].tolist()
        tried = [q[o] if counts[o] > 0 and valid[o] else -math.inf for o in range(len(q))]
        best = max(tried)
        if best == -math.inf:
            return options[0]
        return tried.index(best)  # the first of equal values

    def aimed_border(self, region: torch.Tensor, option: torch.Tensor) -> torch.Tensor:
        """(B,) the index (in the crossing map's borders) of the border each robot's ``option``
        in ``region`` leads across; -1 for the goal, or without crossings."""
        if self.crossings is None:
            return torch.full_like(option, -1)
        return torch.from_numpy(self._border[region.numpy(), option.numpy()])

    @no_grad
    def begin_trial(self, rows: torch.Tensor) -> None:
        """Forget the choices of controllers ``rows`` (their robots start a new trial)."""
        a, r = self.arrays, rows.numpy()
        a["choice"][r] = -1
        self._first[r] = -1
        a["stage"][r] = _FIRST_STAGE
        a["visit"][r] = -1
        self._region_steps[r] = 0
        self._trial_steps[r] = 0
        if self._timeout is not None:
            self._limit[r] = float(self._timeout)
        if self.route is not None:
            self.route.forget(r)
        if self.remembered_way is not None:
            self.remembered_way.begin_trial(r)
        if self.goal_scans is not None:
            self.goal_scans.begin_trial(r)
        if self.wall_follow is not None:
            self.wall_follow.begin_trial(r)
        if self.crossings is not None:  # what is found blocked, from the learned evidence
            self.crossings.forget(r)
            self._trial_stalled[r] = False
            for b in r.tolist():
                self._blocked[b] = [
                    self._crossing(b, j, self._start_xy) is None
                    for j in range(len(self._border_options.borders))
                ]
                self._rehop(b)

    # -- what the update learns from -----------------------------------------------------
    def trial_choices(self, rows: np.ndarray) -> np.ndarray:
        """The trials of controllers ``rows`` as the critic learns from them: the option each
        region was visited with (k, R) (-1: not entered; a copy)."""
        return self.arrays["choice"][rows].copy()

    def trial_first_choices(self, rows: np.ndarray) -> np.ndarray:
        """The option each region of controllers ``rows``' trials was entered with (k, R), before
        any was given up (-1: not entered; a copy)."""
        return self._first[rows].copy()

    def trial_steps(self, rows: np.ndarray) -> np.ndarray:
        """The actions of controllers ``rows``' trials so far (k,) (a copy)."""
        return self._trial_steps[rows].copy()

    def greedy(self, row: int) -> list[int]:
        """The option each region of controller ``row`` would choose greedily (-1: none tried)."""
        critic = self.critic
        q = torch.where((critic.n[row] > 0) & self.valid, critic.q[row], -math.inf)
        best = q.argmax(dim=1)
        return [int(o) if math.isfinite(float(q[r, o])) else -1 for r, o in enumerate(best)]
