"""One set of a study (one robot of a training batch): its result, and its keeping on disk
(``set-K.pt`` in a study's folder of kept sets, with the settings it was run with)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any


@dataclass
class SetResult:
    """One set (one robot of a training batch): its trial rows, chosen paths and controller."""

    index: int
    seed: int
    rows: list[dict[str, Any]]
    paths: dict[int, list[list[float]]] = field(default_factory=dict)
    """Trial number -> true path, for the first, first successful and final trials."""
    ghosts: dict[int, list[list[float]]] = field(default_factory=dict)
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    """Greedy runs of the final controller from other start poses (with their paths)."""
    controller: dict[str, Any] = field(default_factory=dict)
    """The final controller's state dict (loads into a one-robot policy)."""
    timings: dict[str, float] = field(default_factory=dict)
    """Of the training batch this set ran in (shared by the sets of that batch)."""


def _set_settings(data: dict[str, Any], index: int, starts: Sequence[Any]) -> dict[str, Any]:
    return {"config": data, "set": int(index), "starts": [[float(v) for v in s] for s in starts]}


def save_set(folder: str | os.PathLike, s: SetResult, data: dict[str, Any], starts) -> None:
    """Keep set ``s`` in ``folder`` as ``set-K.pt``, with the settings it was run with."""
    import dataclasses
    from pathlib import Path

    from symrl.runs import atomic_save

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    # the fields as they are (dataclasses.asdict deep-copies every row first: a third of the
    # save, for a record that is pickled and dropped)
    fields = {f.name: getattr(s, f.name) for f in dataclasses.fields(s)}
    record = {"settings": _set_settings(data, s.index, starts), "set": fields}
    atomic_save(record, folder / f"set-{s.index:03d}.pt")


def load_set(folder, index: int, data: dict[str, Any], starts) -> SetResult | None:
    """Set ``index`` as saved in ``folder`` if it was run with these settings, else None."""
    from pathlib import Path

    import torch

    path = Path(folder) / f"set-{index:03d}.pt"
    if not path.is_file():
        return None
    try:
        record = torch.load(path, map_location="cpu", weights_only=True)
        if record.get("settings") != _set_settings(data, index, starts):
            return None
        fields = dict(record["set"])
        fields["paths"] = {int(k): v for k, v in fields["paths"].items()}
        fields["ghosts"] = {int(k): v for k, v in fields["ghosts"].items()}
        return SetResult(**fields)
    except Exception:  # noqa: BLE001 - an unreadable or foreign file: run the set again
        return None
