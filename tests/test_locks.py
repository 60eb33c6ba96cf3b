"""Every command that writes an output folder holds its lock: a second command into a folder
another process writes is refused in one line naming the folder, that process and the flag."""

from __future__ import annotations

import os

import pytest

from symrl.cli import main
from symrl.locks import lock_folder

COMMANDS = {
    "drive": ["drive", "--no-noise", "--out", "{out}"],
    "plan": ["plan", "--out", "{out}"],
    "study": ["study", "paper", "--sets", "1", "--trials", "1", "--out", "{out}"],
    "ablate": [
        "ablate",
        "--recipes",
        "reflex_only",
        "--sets",
        "1",
        "--trials",
        "1",
        "--out",
        "{out}",
    ],
    "generalise": ["generalise", "--sets", "1", "--trials", "1", "--out", "{out}"],
    "sweep": [
        "sweep",
        "--recipes",
        "reflex_only",
        "--seeds",
        "1",
        "--trials",
        "1",
        "--out",
        "{out}",
    ],
    "baseline": ["baseline", "sac", "--episodes", "1", "--out", "{out}"],
    "train": ["train", "paper", "--trials", "1", "--logdir", "{out}"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_folder_another_process_writes_is_refused(command, tmp_path, capsys):
    out = tmp_path / "out"
    lock = lock_folder(out, "--out")
    try:
        argv = [a.format(out=out) for a in COMMANDS[command]]
        code = main(argv)
    finally:
        lock.release()
    err = capsys.readouterr().err.strip()
    flag = "--logdir" if command == "train" else "--out"
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert f"{flag} {str(out)!r}" in err and "is writing it now" in err
    assert f"pid {os.getpid()}" in err  # the other process named
    assert f"give another {flag}" in err
    assert sorted(p.name for p in out.iterdir()) == [".lock", ".lock.owner"]  # nothing written


def test_evaluate_locks_its_out(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["train", "reflex_only", "--trials", "1", "--logdir", str(run)]) == 0
    out = tmp_path / "eval"
    lock = lock_folder(out, "--out")
    try:
        code = main(["evaluate", str(run / "checkpoint.pt"), "--out", str(out)])
    finally:
        lock.release()
    err = capsys.readouterr().err
    assert code == 2 and "--out" in err and "is writing it now" in err
    assert main(["evaluate", str(run / "checkpoint.pt"), "--out", str(out)]) == 0


def test_the_lock_is_released_and_a_killed_holder_leaves_none(tmp_path):
    out = tmp_path / "out"
    lock_folder(out, "--out").release()
    again = lock_folder(out, "--out")  # released: taken again at once
    again.release()
    held = lock_folder(out, "--out")
    (out / ".lock.owner").write_text("{broken")  # an unreadable note still gives one line
    try:
        with pytest.raises(FileExistsError, match="another symrl process is writing it now"):
            lock_folder(out, "--out")
    finally:
        held.release()
