"""Paths drawn over a ROS map's own image: what a roboticist checks a controller against."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from symrl.world.occupancy import read_occupancy

__all__ = ["save_paths_on_map"]


def save_paths_on_map(
    map_yaml: str | Path,
    paths: Sequence[np.ndarray | Sequence[Sequence[float]]],
    out: str | Path,
    labels: Sequence[str] = (),
    title: str = "",
) -> Path:
    """Draw ``paths`` (each ``(k, 2)`` metres) over the image of the map_server map
    ``map_yaml`` (placed by its origin and resolution; yaw 0) and save the figure to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    occ = read_occupancy(map_yaml)
    with Image.open(occ.image) as img:
        grey = np.asarray(img.convert("L"))
    width = occ.extent[1] - occ.extent[0]
    height = occ.extent[3] - occ.extent[2]
    scale = 7.0 / max(width, height)
    fig, ax = plt.subplots(figsize=(max(3.0, width * scale) + 1.0, max(3.0, height * scale)))
    ax.imshow(grey, cmap="gray", vmin=0, vmax=255, extent=occ.extent, interpolation="nearest")
    for i, path in enumerate(paths):
        xy = np.asarray(path, dtype=float).reshape(-1, 2)
        label = labels[i] if i < len(labels) else None
        ax.plot(xy[:, 0], xy[:, 1], lw=1.5, label=label)
        ax.plot(xy[0, 0], xy[0, 1], "o", color="tab:green", ms=5)
        ax.plot(xy[-1, 0], xy[-1, 1], "x", color="tab:red", ms=6)
    if labels:
        ax.legend(loc="best", fontsize=8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or occ.image.name)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
