"""The step budget of a trial, following the world's size.

The paper's 200 actions are its world's: 25 actions of optimum in a 7 m x 6.5 m room. A building
needs more, or no trial could reach a goal 50 m away. The budget is the configured one or two
bounding-box half-perimeters of travel (a route that goes round the whole map and back), whichever
is larger: every shipped world stays at 200 (the largest asks for 180), a 30 m x 50 m floor gets
800.
"""

from __future__ import annotations

import math

from symrl.world.worldmap import WorldMap

__all__ = ["step_budget"]


def step_budget(world: WorldMap, max_actions: int, step: float) -> int:
    """Actions a trial in ``world`` may take: ``max_actions``, or ``2 (width + height) / step``
    of the map's bounding box if that is larger."""
    xmin, xmax, ymin, ymax = world.bounds
    return max(int(max_actions), math.ceil(2.0 * ((xmax - xmin) + (ymax - ymin)) / step - 1e-9))
