"""The option tables of the three shipped option sources (``options.source``): ``rules``,
``passages`` and ``map``, each a function of what the robot is told to its table.

``rules`` (rung ``regions``): per region the goal and a point of each border with a region no
farther from the goal's region, the borders the region rules define
(:func:`symrl.knowledge.borders.border_subgoals`). ``passages`` (rung ``passages``): the same
from the passages the robot is told of. ``map`` (rung ``map``): the passages' points behind a
first option, the route, whose point (the goal in the table) moves with the robot
(:class:`symrl.knowledge.route.Route`). The registry that names them is
:mod:`symrl.knowledge.option_sources`.
"""

from __future__ import annotations

from symrl.knowledge.borders import border_subgoals
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable

__all__ = ["ROUTE", "rule_options", "passage_options", "map_options"]

ROUTE = "route"
"""The route option's label in an option table: a robot told the map follows the planner's
path there (:class:`symrl.knowledge.route.Route`); below ``map`` building it is an error."""


def rule_options(knowledge: Knowledge) -> SubgoalTable:
    """``rules``: the goal and a point of each region rules' border toward the goal's
    region."""
    return border_subgoals(knowledge.regions, knowledge.goal)


def passage_options(knowledge: Knowledge) -> SubgoalTable:
    """``passages``: the goal and a point of each passage the robot is told of toward the
    goal's region."""
    return border_subgoals(knowledge.regions, knowledge.goal, knowledge.passages)


def map_options(knowledge: Knowledge) -> SubgoalTable:
    """``map``: the route, then the passages' options (an error naming the rung below
    ``map``)."""
    knowledge.geometry("the route option")
    table = passage_options(knowledge)
    goal = (float(knowledge.goal.x), float(knowledge.goal.y))
    per_region = [
        [(goal, ROUTE)]
        + [
            ((float(x), float(y)), label)
            for (x, y), label, ok in zip(
                table.points[i].tolist(), labels, table.valid[i].tolist(), strict=False
            )
            if ok
        ]
        for i, labels in enumerate(table.labels)
    ]
    return SubgoalTable.of(table.region_names, per_region)
