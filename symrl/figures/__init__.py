"""Every figure symrl writes: trial paths, the reflex's drive, the optimum, learning curves,
recipe comparisons, baselines.

The map itself is drawn by ``symrl.world.render`` (the world's own drawing primitives on an
Axes); these functions compose figures on top of it. Every ``plot_*`` writes one PNG and closes
its figure, so long studies do not accumulate open figures. Trial axes have integer ticks; paths
start with a marker; curves that coincide stay visible (each recipe its own marker, line style
and a small horizontal offset). Figures laid out by ``tight_layout`` are saved without
``bbox_inches="tight"``, which would draw the whole figure once more (about a sixth of a
study's drawing time) for the same margins. The study's figures (:func:`plot_paths`,
:func:`plot_curves`) have fixed margins in inches
(:func:`symrl.figures.parts.fixed_margins`) instead: their panels are always the same kind, and
``tight_layout`` measures every tick label by laying the figure out once more, about a third of
their drawing time (measured on a study's three figures: 0.22 / 0.13 / 0.14 s -> 0.15 / 0.09 /
0.09 s).

The modules by job: :mod:`~symrl.figures.parts` (what the figures share),
:mod:`~symrl.figures.maps` (figures on the map), :mod:`~symrl.figures.charts` (curves and bars)
and :mod:`~symrl.figures.parallel` (drawing them in parallel).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402, F401 - symrl.drawing draws with symrl.figures.plt

from symrl.figures.charts import (  # noqa: E402
    plot_baseline,
    plot_comparison,
    plot_curves,
    plot_ladder_worlds,
    plot_learning_curves,
    plot_map_comparison,
)
from symrl.figures.maps import (  # noqa: E402
    crossings_figure,
    drive_figure,
    plot_crossings,
    plot_paths,
    plot_plan,
    plot_reward_optimum,
    trajectory_figure,
)
from symrl.figures.parallel import draw_in_parallel  # noqa: E402
from symrl.figures.parts import draw_map  # noqa: E402

__all__ = [
    "draw_map",
    "trajectory_figure",
    "drive_figure",
    "plot_plan",
    "plot_paths",
    "plot_curves",
    "plot_comparison",
    "plot_map_comparison",
    "plot_baseline",
    "plot_learning_curves",
    "plot_reward_optimum",
    "plot_ladder_worlds",
    "draw_in_parallel",
    "crossings_figure",
    "plot_crossings",
]
