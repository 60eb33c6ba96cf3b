"""What the robot is told: the knowledge ladder, and the one object an agent is built from.

The paper's question is what symbolic knowledge buys a numeric learner, so what the robot knows is
an input, declared by every recipe (``knowledge:``) and handed to the agent as a
:class:`Knowledge`, which holds its rung's content and nothing more. The env keeps the whole
world; the studies' yardsticks (the planner's optimum) are computed from the world, never from
an agent's knowledge below ``map``.

The rungs, each adding to the one below:

``sensors``
    the robot's own sensors (sonar, IR, bumpers) and odometry, its fuzzy reflex, a model of its
    own motion and of the reward's definition, the start pose and the goal.
``regions``
    + the symbolic region rules (names, lines, first-match rules, and what follows from them
    alone): the paper's robot (Hailu 2001, sections 3.2 and 6).
``passages``
    + where the regions really connect: the passages (doors) between regions as symbolic
    segments of the region lines, found in the map by a map tool (``find_passages``) and handed
    over without the walls: a topological map.
``map``
    + the full geometry: walls, the free-space polygon, the passages found in it, shortest paths
    (the planner) and map localisation.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Literal, get_args

from symrl.knowledge.borders import Border, passages_of
from symrl.world.worldmap import Goal, Pose, RegionRule, RegionSpec, WorldMap

__all__ = ["Rung", "RUNGS", "Knowledge", "rung_at_least", "TOLD"]

Rung = Literal["sensors", "regions", "passages", "map"]
RUNGS: tuple[Rung, ...] = get_args(Rung)
"""The rungs in order, each told everything the one before it is."""

TOLD: dict[str, str] = {
    "sensors": "reflex, own sensors and odometry, start and goal",
    "regions": "+ the region rules (the paper's robot)",
    "passages": "+ the passages between regions (a topological map, no walls)",
    "map": "+ walls, free-space polygon, planner, map localisation",
}
"""What a robot on each rung is told, in a few words (tables and ``--help``)."""

_ONE_REGION = RegionSpec(names=("all",), lines={}, rules=(RegionRule("all", ()),))


def rung_at_least(rung: str, needed: str) -> bool:
    """True when ``rung`` is told everything ``needed`` is."""
    return RUNGS.index(rung) >= RUNGS.index(needed)  # type: ignore[arg-type]


@dataclass(frozen=True)
class Knowledge:
    """What an agent on ``rung`` is told about a world (build it with :meth:`told`).

    ``regions`` is the map's region rules from ``regions`` up, a single region ``all`` below;
    ``world`` (the walls, the free-space polygon) is there only at ``map``. A part of the agent
    that needs the world asks :meth:`geometry`, which names the rung when it is missing.
    """

    rung: Rung
    name: str
    """The map's name (labels only)."""
    start: Pose
    goal: Goal
    regions: RegionSpec
    doors: tuple[Border, ...] | None = None
    """At ``passages``: the passages handed over (read them as :attr:`passages`)."""
    world: WorldMap | None = None

    @classmethod
    def told(cls, world: WorldMap, rung: str) -> Knowledge:
        """The part of ``world`` a robot on ``rung`` is told."""
        if rung not in RUNGS:
            raise ValueError(f"knowledge={rung!r}: unknown; the rungs are {', '.join(RUNGS)}")
        return cls(
            rung=rung,  # type: ignore[arg-type]
            name=world.name,
            start=world.start,
            goal=world.goal,
            regions=world.regions if rung_at_least(rung, "regions") else _ONE_REGION,
            doors=passages_of(world) if rung == "passages" else None,
            world=world if rung == "map" else None,
        )

    @functools.cached_property
    def passages(self) -> tuple[Border, ...] | None:
        """From ``passages`` up: the stretches of the region lines where two regions connect
        through free space (oriented as ``Border``s); None below. At ``map`` they are found
        in the world when first asked for (tens of milliseconds)."""
        if self.doors is not None:
            return self.doors
        return passages_of(self.world) if self.world is not None else None

    def geometry(self, what: str) -> WorldMap:
        """The world's geometry, for ``what`` (a part of the agent); an error below ``map``."""
        if self.world is None:
            raise ValueError(
                f"{what} needs knowledge=map (the walls), but the robot is told "
                f"knowledge={self.rung}"
            )
        return self.world
