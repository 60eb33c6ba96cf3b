r"""A knowledge source of your own: sub-goal options at the middle of each border
(docs/how-to/add-a-knowledge-source.md).

Told the region rules (``knowledge: regions``), a robot knows where two regions meet (the
borders: a stretch of a named line with a different region on each side) and which borders lead
on toward the goal's region, but not where the walls are. The shipped ``rules`` source puts a
border's option at the border's point nearest the goal; this source puts it at the border's
middle: the middle of its stretch, ``DEPTH`` metres in from its one end where the stretch runs
on without end, level with the goal where it has no end at all. Importing the module registers
the source ``middles``; a recipe or an override names it by the module's dotted path:

    PYTHONPATH=. symrl train paper options.source=examples.border_middles:middles \
        crossings.enabled=false

    python examples/border_middles.py   # the paper's world: each option, here and in ``rules``
"""

from __future__ import annotations

import math

from symrl.knowledge.borders import Border, region_borders, region_hops
from symrl.knowledge.option_sources import option_table, register_option_source
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable

DEPTH = 1.0
"""Metres in from a border's one end, where its stretch runs on without end."""
BEYOND = 0.4
"""Metres past the line, into the region the option leads to."""
MERGE = 0.3
"""An option nearer than this to one before it in its region's row is left out."""


def middle(border: Border, level: float) -> float:
    """Where along its line the option of ``border`` lies (``level``: the goal's coordinate
    along the line)."""
    lo, hi = border.lo, border.hi
    if math.isfinite(lo) and math.isfinite(hi):
        return (lo + hi) / 2
    if math.isfinite(lo):
        return lo + DEPTH
    if math.isfinite(hi):
        return hi - DEPTH
    return level


@register_option_source("middles", rung="regions")
def middles(knowledge: Knowledge) -> SubgoalTable:
    """Per region: the goal, then the middle of each border with a region no farther from the
    goal's region (in borders crossed), ``BEYOND`` metres into that region (unless it lies
    within ``MERGE`` of an option before it)."""
    spec, goal = knowledge.regions, (float(knowledge.goal.x), float(knowledge.goal.y))
    borders = region_borders(spec)  # from the rules alone: no walls at this rung
    hops = region_hops(spec, borders, knowledge.goal)
    per_region = []
    for region in spec.names:
        row = [(goal, "goal")]
        for b in borders:
            if region not in (b.low, b.high):
                continue
            other = b.high if region == b.low else b.low
            if hops.get(other, math.inf) > hops.get(region, math.inf):
                continue  # leads away from the goal's region
            t = middle(b, goal[1] if b.axis == 0 else goal[0])
            xy = b.at(t, BEYOND if other == b.high else -BEYOND)
            if all(math.dist(xy, q) >= MERGE for q, _ in row):
                row.append((xy, f"{b.line}>{other}"))
        per_region.append(row)
    return SubgoalTable.of(tuple(spec.names), per_region)


def main() -> None:
    from symrl.world.worldmap import load_map

    told = Knowledge.told(load_map("hailu2001"), "regions")
    mine, rules = option_table(told, "middles"), option_table(told, "rules")
    for r, region in enumerate(mine.region_names):
        for k, label in enumerate(mine.labels[r]):
            here = [round(v, 3) for v in mine.point(r, k)]
            there = rules.point(r, rules.labels[r].index(label)) if label in rules.labels[r] else ()
            print(f"{region:10s} {label:14s} middles {here}  rules {[round(v, 3) for v in there]}")


if __name__ == "__main__":
    main()
