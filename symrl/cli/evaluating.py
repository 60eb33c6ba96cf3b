"""The work of ``symrl evaluate``: load a saved controller (a learner's checkpoint or a
baseline's), choose the world it drives in, drive one greedy trial and draw its path.

Imported by the command when it runs: it brings torch and matplotlib with it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from symrl.evaluate import evaluate
from symrl.figures import trajectory_figure
from symrl.runs import CheckpointError, load_checkpoint_world
from symrl.world.worldmap import WorldMap, load_map


@dataclass
class Controller:
    """A saved controller and the world it learned in: a learner's policy and config, or a
    baseline (which drives itself)."""

    world: WorldMap
    policy: Any = None
    config: Any = None
    baseline: Any = None

    def greedy(self, start: Any, seed: int, world: WorldMap) -> dict[str, Any]:
        """One greedy trial from ``start`` (None: the map's start) in ``world``."""
        if self.baseline is not None:
            (record,) = self.baseline.evaluate([start], seed=seed, world=world)
        else:
            (record,) = evaluate(self.policy, self.config, starts=[start], seed=seed, world=world)
        return record


def load_controller(checkpoint: str) -> Controller:
    """The controller saved in the file ``checkpoint`` (a folder is a one-line error)."""
    if Path(checkpoint).is_dir():
        raise CheckpointError(
            f"checkpoint {checkpoint!r}: is a folder; pass the checkpoint.pt file in it"
        )
    from symrl.studies.baseline import load_baseline

    baseline = load_baseline(checkpoint)  # a baseline's checkpoint, else None
    if baseline is not None:
        return Controller(world=baseline.world, baseline=baseline)
    policy, config, learned_in = load_checkpoint_world(checkpoint)
    return Controller(world=learned_in, policy=policy, config=config)


def driven_in(trained_on: WorldMap, map_: str | None, other_map: bool) -> tuple[WorldMap, bool]:
    """The world to drive in (``--map``, else the one the controller learned in) and whether it
    is another one, which needs ``--other-map``."""
    world = trained_on
    if map_ is not None:
        world = load_map(map_)
    elif other_map:
        raise ValueError("--other-map: only with --map (the map to drive in)")
    other = map_ is not None and not same_map(trained_on, world)
    if other and not other_map:
        raise ValueError(
            f"--map {map_}: the controller learned in map {trained_on.name!r} (its regions "
            f"and goal); it would drive in {world.name!r} told the old map's. Pass --other-map "
            "to drive it there anyway"
        )
    return world, other


def same_map(a: Any, b: Any) -> bool:
    """Whether two loaded maps are the same world (name, walls, start and goal)."""
    return bool(
        a.name == b.name
        and a.goal == b.goal
        and a.start == b.start
        and a.segments.shape == b.segments.shape
        and np.array_equal(a.segments, b.segments)
    )


def save_figure(world: WorldMap, record: dict[str, Any], out: Path) -> None:
    """The trial's path in ``out/evaluate.png``."""
    out.mkdir(parents=True, exist_ok=True)
    title = f"greedy: {record['steps']} actions, total {record['total_reinforcement']:.2f}"
    fig = trajectory_figure(world, record, title=title)
    fig.savefig(out / "evaluate.png", dpi=120)
    plt.close(fig)
