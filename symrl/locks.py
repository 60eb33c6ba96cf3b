"""One writer per output folder: every command that writes a folder holds ``FOLDER/.lock`` while
it does, so a second command into the same folder is refused in one line (naming the folder, the
process that holds it and the flag to change) instead of mixing or replacing the first's files.

The lock is an OS lock (``filelock``: flock on Linux and macOS), so a killed process leaves no
stale lock. Who holds it is written beside it (``.lock.owner``: pid, command line, start time),
only to be named in the refusal.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["FolderLocked", "lock_folder", "holding"]

LOCK_NAME = ".lock"
OWNER_NAME = ".lock.owner"


class FolderLocked(FileExistsError):
    """Another process writes the folder now (an input error: one line)."""


def _owner_text(folder: Path) -> str:
    """``pid N, `symrl ...`, since HH:MM:SS`` of the process holding ``folder``'s lock, as far
    as it wrote it down."""
    try:
        owner = json.loads((folder / OWNER_NAME).read_text())
        pid, command, since = int(owner["pid"]), str(owner["command"]), float(owner["since"])
    except (OSError, ValueError, KeyError, TypeError):
        return "another symrl process"
    started = time.strftime("%H:%M:%S", time.localtime(since))
    return f"another symrl process (pid {pid}, `{command}`, since {started})"


def _command_line() -> str:
    argv = [Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "symrl", *sys.argv[1:]]
    if argv[0] in ("__main__.py", "-m", "-c", "python"):
        argv[0] = "symrl"
    text = " ".join(argv)
    return text if len(text) <= 160 else text[:157] + "..."


def lock_folder(folder: str | Path, flag: str) -> Any:
    """Make ``folder`` if needed and take its lock (a ``filelock.FileLock``, held until
    released); :class:`FolderLocked` naming ``flag`` if another process holds it."""
    from filelock import FileLock, Timeout

    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise FileExistsError(f"{flag} {str(folder)!r}: cannot make it ({err.strerror})") from None
    lock = FileLock(folder / LOCK_NAME)
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise FolderLocked(
            f"{flag} {str(folder)!r}: {_owner_text(folder)} is writing it now (it holds "
            f"{str(folder / LOCK_NAME)!r}); wait for it to end or give another {flag}"
        ) from None
    except OSError as err:
        raise FileExistsError(
            f"{flag} {str(folder)!r}: cannot write in it ({err.strerror})"
        ) from None
    with contextlib.suppress(OSError):
        (folder / OWNER_NAME).write_text(
            json.dumps({"pid": os.getpid(), "command": _command_line(), "since": time.time()})
            + "\n"
        )
    return lock


@contextlib.contextmanager
def holding(folder: str | Path, flag: str) -> Iterator[Path]:
    """``with holding(out, "--out"):`` the command's output folder locked for its whole run. A
    folder made here is removed again if the run fails before writing anything into it (a bad
    input found by the command leaves no empty folder behind)."""
    path = Path(folder)
    made = not path.exists()
    lock = lock_folder(path, flag)
    try:
        yield path
    except BaseException:
        lock.release()
        if made:
            _remove_if_empty(path)
        raise
    lock.release()


def _remove_if_empty(folder: Path) -> None:
    """Remove ``folder`` if it holds nothing but the lock's files."""
    try:
        if {p.name for p in folder.iterdir()} <= {LOCK_NAME, OWNER_NAME}:
            for name in (LOCK_NAME, OWNER_NAME):
                (folder / name).unlink(missing_ok=True)
            folder.rmdir()
    except OSError:
        pass
