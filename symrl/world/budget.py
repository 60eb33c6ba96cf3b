"""The step budget of a trial, following the world's size.

The paper's 200 actions are its world's: 40 m of travel (200 moves of 0.20 m) for a route of
25 actions in a 7 m x 6.5 m room. A building needs more, or no trial could reach a goal 50 m
away. The configured budget holds for every map up to two bounding-box half-perimeters of 40 m
(every shipped world: the largest has 36 m) and grows in proportion beyond: a 30 m x 50 m floor
(160 m) gets four times the configured budget, 800 actions for the paper's 200.
"""

from __future__ import annotations

import math

from symrl.world.worldmap import WorldMap

__all__ = ["step_budget", "PAPER_BUDGET"]

PAPER_BUDGET = 200
"""The paper's actions per trial; ``PAPER_BUDGET * step`` metres is the travel it allows."""


def step_budget(world: WorldMap, max_actions: int, step: float) -> int:
    """Actions a trial in ``world`` may take: ``max_actions``, times the map's two bounding-box
    half-perimeters over the paper's travel (``PAPER_BUDGET * step``) when that exceeds 1."""
    xmin, xmax, ymin, ymax = world.bounds
    scale = 2.0 * ((xmax - xmin) + (ymax - ymin)) / (PAPER_BUDGET * step)
    return max(int(max_actions), math.ceil(max_actions * scale - 1e-9))
