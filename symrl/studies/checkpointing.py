"""A study's batches saved as they train, so a study stopped at any moment (Ctrl-C, SIGTERM,
SIGHUP, ``kill -9``) goes on from where it was and ends in the trial table of a run never
stopped.

The sets of a study train side by side in one batch per worker, so no set is finished before
the batch is. Each batch therefore writes its whole state (:func:`symrl.train.batch_snapshot`:
learners, random streams, robots mid-trial, trial rows) into the study's folder of kept sets,
``batch-K1-K2-....pt`` (a batch of many sets: its first and last set, their count and a
digest), at the first trial boundary after every :data:`INTERVAL_S` seconds (atomically: a kill
leaves the previous one). A batch of the same sets and settings started again loads it and goes
on exactly; a finished batch saves its sets (``set-K.pt``) and drops its state.
"""

from __future__ import annotations

import contextlib
import hashlib
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

__all__ = ["BatchKeeper", "INTERVAL_S", "batch_files", "begin", "end", "forget_kept", "running"]

INTERVAL_S = 2.0
"""Seconds of training a stop may lose at most (a snapshot costs a few milliseconds)."""


def batch_files(folder: str | Path) -> list[Path]:
    """The saved batch states in a study's folder of kept sets."""
    return sorted(Path(folder).glob("batch-*.pt"))


def _sets_label(indices: Sequence[int]) -> str:
    """The sets of a batch in its file's name: every index while the name stays short, else
    the first, the last, the count and a digest of them all (a file name has at most 255
    bytes; the file's own settings say which sets it holds)."""
    label = "-".join(f"{int(k):03d}" for k in indices)
    if len(label) <= 80:
        return label
    digest = hashlib.sha1(label.encode()).hexdigest()[:12]
    return f"{int(indices[0]):03d}-{int(indices[-1]):03d}-n{len(indices)}-{digest}"


class BatchKeeper:
    """Saves and finds the state of one batch of sets (``indices``) of a study."""

    def __init__(
        self,
        folder: str | Path,
        config_data: dict[str, Any],
        indices: Sequence[int],
        starts: Sequence[Any],
    ) -> None:
        self.folder = Path(folder)
        self.path = self.folder / f"batch-{_sets_label(indices)}.pt"
        self.settings = {
            "config": config_data,
            "sets": [int(k) for k in indices],
            "starts": [[float(v) for v in s] for s in starts],
        }
        self._last = time.monotonic()

    def saved(self) -> dict[str, Any] | None:
        """The state this batch was stopped in, if one with the same settings is saved."""
        import torch

        if not self.path.is_file():
            return None
        try:
            record = torch.load(self.path, map_location="cpu", weights_only=False)
        except Exception:  # noqa: BLE001 - unreadable: the batch starts afresh
            return None
        if not isinstance(record, dict) or record.get("settings") != self.settings:
            return None
        return record.get("state")

    def on_boundary(self, snapshot: Callable[[], dict[str, Any]]) -> None:
        """At a trial boundary: save the batch's state if :data:`INTERVAL_S` has passed."""
        now = time.monotonic()
        if now - self._last < INTERVAL_S:
            return
        from symrl.runs import atomic_save

        self.folder.mkdir(parents=True, exist_ok=True)
        atomic_save({"settings": self.settings, "state": snapshot()}, self.path)
        self._last = time.monotonic()

    def done(self) -> None:
        """The batch's sets are saved: its state is dropped."""
        self.path.unlink(missing_ok=True)


# --- a stopped command in its output folder ----------------------------------------------------

STOPPED_NAME = "stopped.json"
"""Written into a command's output folder when it starts and removed when it ends: found there,
it marks a command that was stopped (or killed) and can go on with ``--resume``."""


def _difference(saved: dict[str, Any], given: dict[str, Any]) -> str:
    keys = [k for k in sorted(set(saved) | set(given)) if saved.get(k) != given.get(k)]
    return ", ".join(f"{k} {saved.get(k)!r} there, {given.get(k)!r} now" for k in keys[:3])


def begin(
    out: str | Path,
    command: str,
    settings: dict[str, Any],
    resume: bool,
    overwrite: bool | None = None,
) -> bool:
    """Mark ``out`` as written by a running ``symrl command`` with ``settings`` (plain JSON
    values), after checking it against what the folder holds, each fault one line: a stopped
    run there goes on only with ``resume`` and the same settings, or is replaced with
    ``overwrite`` (``None``: the command has no --overwrite); ``resume`` with no stopped run
    there is an error. Returns whether a stopped run goes on."""
    import json

    folder = Path(out)
    marker = folder / STOPPED_NAME
    saved: dict[str, Any] | None = None
    if marker.is_file():
        try:
            loaded = json.loads(marker.read_text())
            saved = loaded if isinstance(loaded, dict) else {}
        except (OSError, ValueError):
            saved = {}
    afresh = "" if overwrite is None else ", or start afresh with --overwrite"
    if saved is not None and not resume and not overwrite:
        raise ValueError(
            f"--out {str(folder)!r}: holds a stopped `symrl {command}` (its finished trials are "
            f"kept there); go on with the same command and --resume{afresh}, or give another "
            "--out"
        )
    if resume and saved is None:
        raise ValueError(
            f"--resume: --out {str(folder)!r} holds no stopped `symrl {command}` to go on with "
            "(leave --resume out to start one)"
        )
    if resume and saved != settings:
        raise ValueError(
            f"--resume: --out {str(folder)!r} holds a stopped `symrl {command}` of other settings "
            f"({_difference(saved or {}, settings) or 'unreadable'}); give the same ones"
            f"{afresh.replace(', or', ' or')}"
        )
    folder.mkdir(parents=True, exist_ok=True)
    marker.write_text(json.dumps(settings, sort_keys=True) + "\n")
    return bool(resume)


def end(out: str | Path) -> None:
    """The command ended: its folder holds no stopped run any more."""
    (Path(out) / STOPPED_NAME).unlink(missing_ok=True)


def forget_kept(folder: str | Path) -> None:
    """Drop the kept sets and batch states of a stopped study (``--overwrite``)."""
    for path in [*Path(folder).glob("set-*.pt"), *batch_files(folder)]:
        path.unlink(missing_ok=True)


@contextlib.contextmanager
def running(
    out: str | Path,
    command: str,
    settings: dict[str, Any],
    resume: bool,
    overwrite: bool | None = None,
) -> Iterator[bool]:
    """:func:`begin`, the command's work, then :func:`end`; a stop (Ctrl-C, SIGTERM, SIGHUP,
    or a kill, which runs nothing) leaves the folder marked as stopped; an error does not
    (a run that failed is not one to go on with). Yields whether a stopped run goes on."""
    going_on = begin(out, command, settings, resume, overwrite)
    try:
        yield going_on
    except KeyboardInterrupt:
        raise
    except BaseException:
        end(out)
        raise
    end(out)
