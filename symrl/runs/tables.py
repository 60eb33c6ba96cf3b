"""A run's trial table: its columns, and ``trials.csv`` written and read back; a config's
settings flattened to dotted keys (the table of ``config.yaml`` in TensorBoard)."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

from symrl.learner.config import RunConfig
from symrl.learner.experts import expert_names

BASE_COLUMNS: tuple[str, ...] = (
    "trial",
    "steps",
    "total_reinforcement",
    "collisions",
    "shielded",
    "reached_goal",
    "neurons",
    "temperature",
    "replaced",
    "improved",
    "mean_abs_td_error",
    "path_length",
)
"""The columns every trial table starts with (a learner fills those it has)."""


def trial_columns(config: RunConfig, world: Any) -> list[str]:
    """Columns of the trial table of a run (fixed before its first trial)."""
    columns = list(BASE_COLUMNS)
    columns += [f"neurons_{name}" for name in expert_names(config, world)]
    if config.options.enabled:
        columns += [f"option_{name}" for name in world.regions.names]
    if config.crossings.enabled:
        columns += ["crossings_open_m", "crossings_blocked_m", "borders_blocked"]
        if config.crossings.dead_ends:
            columns += ["crossings_dead_end_m"]
    if config.options.enabled and config.options.goal_scans:
        columns += ["goal_passed", "goal_refound"]
    if config.options.enabled and config.options.wall_follow:
        columns += ["wall_follows"]
    if config.scan_odometry.enabled:
        columns += ["scan_correction_m"]
    return columns


def fmt(value: Any) -> Any:
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return value


def write_trials_csv(
    path: str | Path, rows: list[dict[str, Any]], columns: list[str] | None = None
) -> None:
    """One row per trial (or per set and trial), every scalar column; paths are left out."""
    if columns is None:
        seen: dict[str, None] = {}
        for row in rows:
            for k, v in row.items():
                if not isinstance(v, (list, tuple, dict)):
                    seen.setdefault(k)
        columns = list(seen)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: fmt(row[k]) for k in columns if k in row})


def read_trials_csv(path: str | Path) -> list[dict[str, Any]]:
    """Read a trial table back with numbers as numbers."""

    def num(v: str) -> Any:
        if v in ("True", "False"):
            return v == "True"
        for kind in (int, float):
            try:
                return kind(v)
            except ValueError:
                pass
        return v

    with open(path, newline="") as fh:
        return [{k: num(v) for k, v in row.items() if v != ""} for row in csv.DictReader(fh)]


def flat(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested settings as dotted key -> value (the reflex's ``near`` and ``sectors`` kept whole)."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict) and key not in ("near", "sectors"):
            out.update(flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out
