"""The shipped worlds in one go: a picture of each, its planner optimum and its option tables.

Run from the repository root: ``python docs/scripts/map_gallery.py`` writes
``docs/figures/maps/<name>.png`` (hand regions) and ``<name>_auto.png`` (regions found from the
walls, ``regions: auto``) and prints the Markdown tables used in ``docs/reference/map-format.md``.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from symrl.knowledge.planner import shortest_path
from symrl.knowledge.route import ROUTE, option_table
from symrl.knowledge.rungs import Knowledge
from symrl.knowledge.subgoals import SubgoalTable
from symrl.world.autoregions import auto_regions
from symrl.world.render import save_map_figure
from symrl.world.worldmap import builtin_maps, load_map

OUT = Path("docs/figures/maps")


def table_of(world) -> SubgoalTable:
    """``paper_map``'s option table (told the map): the route, the goal, the passages' points."""
    return option_table(Knowledge.told(world, "map"), "map")


def fixed_points(table: SubgoalTable) -> list[list[float]]:
    """The table's points but the route's (which moves with the robot)."""
    return [
        p
        for r, row in enumerate(table.labels)
        for k, (label, p) in enumerate(zip(row, table.points[r].tolist(), strict=False))
        if label != ROUTE and bool(table.valid[r, k])
    ]


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    print("| map | shortest path (m) | actions of 0.20 m |")
    print("|---|---|---|")
    tables = []
    for name in builtin_maps():
        world = load_map(name)
        plan = shortest_path(world)
        table = table_of(world)
        points = fixed_points(table)
        save_map_figure(world, OUT / f"{name}.png", plan.points, subgoals=points)
        print(f"| `{name}` | {plan.length:.3f} | {plan.actions} |")
        tables.append((name, table))
        found = auto_regions(world.boundary, world.obstacles, world.extra_segments)
        doc = yaml.safe_load(Path(world.source).read_text()) | {"regions": "auto"}
        auto = load_map(doc)
        auto_table = table_of(auto)
        auto_points = fixed_points(auto_table)
        save_map_figure(
            auto, OUT / f"{name}_auto.png", title=f"{name}, regions: auto", subgoals=auto_points
        )
        if name == "hailu2001":
            tables.append((f"{name}, regions: auto", auto_table))
            print("\n" + yaml.safe_dump({"regions": found}, default_flow_style=None, width=99))
    for name, table in tables:
        print(f"\n`{name}` (`paper_map`):\n")
        print("| region | options |")
        print("|---|---|")
        for r, region in enumerate(table.region_names):
            opts = ", ".join(
                label if label == ROUTE else f"{label} ({x:.2f}, {y:.2f})"
                for label, (x, y) in zip(
                    table.labels[r], table.points[r][table.valid[r]].tolist(), strict=True
                )
            )
            print(f"| {region} | {opts} |")


if __name__ == "__main__":
    main()
