"""The figures of the shipped ROS world ``ros_lab``: its gallery picture and a trained path.

Run from the repository root: ``python docs/scripts/ros_lab_figures.py`` writes
``docs/figures/maps/ros_lab.png`` (the traced walls, the regions found from them, the optimum
and ``paper_map``'s fixed sub-goals, as ``map_gallery.py`` draws every shipped world) and
``docs/figures/ros_lab_paths.png`` (``paper_map``'s tenth trial, seed 100, and the shortest
path over the saved map's own image), and prints the optimum and the ten trials' actions.
"""

from __future__ import annotations

from pathlib import Path

from map_gallery import fixed_points, table_of

from symrl.knowledge.planner import shortest_path
from symrl.learner.config import load_config
from symrl.train import train
from symrl.world.occupancy_figure import save_paths_on_map
from symrl.world.render import save_map_figure
from symrl.world.worldmap import load_map

FIGURES = Path("docs/figures")


def main() -> None:
    world = load_map("ros_lab")
    plan = shortest_path(world)
    save_map_figure(
        world, FIGURES / "maps" / "ros_lab.png", plan.points, subgoals=fixed_points(table_of(world))
    )
    config = load_config("paper_map", ["env.map=ros_lab", "run.trials=10", "run.seed=100"])
    result = train(config, progress=False)
    print(f"optimum {plan.actions} actions; trials: {[r['steps'] for r in result.trials]}")
    save_paths_on_map(
        "symrl/world/maps/ros/lab.yaml",
        [plan.points, result.trials[-1]["path"]],
        FIGURES / "ros_lab_paths.png",
        labels=["shortest path", "trial 10"],
        title="ros_lab: paper_map, trial 10 of 10, over the saved map",
    )


if __name__ == "__main__":
    main()
