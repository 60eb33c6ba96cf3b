"""A study, an ablation or a sweep stopped at any moment (Ctrl-C, SIGTERM, SIGHUP, ``kill -9``)
keeps its progress, refuses to start again over it without ``--resume``, and the same command
with ``--resume`` ends in the trial tables of the run never stopped, byte for byte.

The stopped command runs in a forked copy of this process (its batch states saved at every
trial boundary, ``INTERVAL_S`` 0) and is signalled once it has saved some progress."""

from __future__ import annotations

import contextlib
import glob
import io
import multiprocessing
import os
import signal
import sys
import time
from pathlib import Path

import pytest

import symrl.studies.checkpointing as checkpointing
import symrl.studies.sweep as sweep
from symrl.cli import main
from symrl.runs import finished_trials

COMMANDS = {
    "study": (
        ["study", "paper_map", "--sets", "3", "--trials", "5"],
        "sets/batch-*.pt",
        ["trials.csv"],
    ),
    # `paper` on a closet world: its robots follow walls and mark dead ends (working state
    # beyond the state dicts)
    "study_paper": (
        ["study", "paper", "--sets", "2", "--trials", "4", "--map", "tuning/closet_first_door"],
        "sets/batch-*.pt",
        ["trials.csv"],
    ),
    "ablate": (
        ["ablate", "--recipes", "reflex_only,paper_map", "--sets", "2", "--trials", "4"],
        "paper_map/sets/batch-*.pt",
        ["reflex_only/trials.csv", "paper_map/trials.csv"],
    ),
    "sweep": (
        ["sweep", "--recipes", "paper,paper_map", "--seeds", "1", "--trials", "4"],
        "runs/paper_map__hailu2001__s1/checkpoint.pt",
        [
            "runs/paper__hailu2001__s1/trials.csv",
            "runs/paper_map__hailu2001__s1/trials.csv",
            "summary.md",
        ],
    ),
}


def _quiet(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, err.getvalue()


@pytest.fixture(autouse=True)
def _save_at_every_boundary(monkeypatch):
    monkeypatch.setattr(checkpointing, "INTERVAL_S", 0.0)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """Each command's results, run once without a stop."""
    root = tmp_path_factory.mktemp("whole")
    out = {}
    for name, (argv, _, _) in COMMANDS.items():
        out[name] = root / name
        assert _quiet([*argv, "--out", str(out[name])])[0] == 0
    return out


def _stopped(argv: list[str], out: Path, saved: str, sig: int, delay: float) -> tuple[int, str]:
    """Run ``argv`` in a fork, send it ``sig`` once ``saved`` exists (and ``delay`` later)."""
    err_file = out.parent / f"{out.name}.err"

    def child() -> None:
        sys.stderr = open(err_file, "w")  # noqa: SIM115 - the fork ends below
        with contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        sys.stderr.flush()
        os._exit(code)

    process = multiprocessing.get_context("fork").Process(target=child)
    process.start()
    waited = time.monotonic()
    while not glob.glob(str(out / saved)) and time.monotonic() - waited < 120:
        time.sleep(0.02)
    time.sleep(delay)
    os.kill(process.pid, sig)
    process.join(120)
    return process.exitcode, err_file.read_text() if err_file.exists() else ""


@pytest.mark.parametrize(
    ("command", "sig", "workers", "delay"),
    [
        ("study", signal.SIGINT, 1, 0.0),
        ("study", signal.SIGTERM, 2, 0.3),
        ("study", signal.SIGHUP, 1, 0.5),
        ("study", signal.SIGKILL, 2, 0.2),
        ("study_paper", signal.SIGKILL, 1, 0.3),
        ("ablate", signal.SIGTERM, 1, 0.0),
        ("ablate", signal.SIGKILL, 2, 0.3),
        ("sweep", signal.SIGINT, 1, 0.0),
        ("sweep", signal.SIGKILL, 2, 0.2),
    ],
)
def test_a_stopped_command_resumes_to_the_uninterrupted_tables(
    command, sig, workers, delay, uninterrupted, tmp_path, monkeypatch
):
    argv, saved, tables = COMMANDS[command]
    out = tmp_path / "out"
    argv = [*argv, "--workers", str(workers), "--out", str(out)]
    code, err = _stopped(argv, out, saved, sig, delay)
    if sig == signal.SIGKILL:
        assert code == -signal.SIGKILL
    else:  # ended by the signal, with the one stop message and no traceback
        name = "Ctrl-C" if sig == signal.SIGINT else signal.Signals(sig).name
        assert code in (128 + sig, 0), err  # 0: it had just finished
        if code:
            assert f"symrl {command}: stopped by {name}; its progress is saved in" in err
            assert "--resume" in err and "Traceback" not in err
    if code != 0:
        assert (out / checkpointing.STOPPED_NAME).is_file()
        refused, message = _quiet(argv)  # not started again over it without --resume
        assert refused == 2 and "holds a stopped" in message and "--resume" in message
    resumed: list[str] = []
    real = sweep._stopped_state
    stopped_runs = [
        run
        for run in (out / "runs").glob("*")
        if command == "sweep"
        and code
        and (run / "checkpoint.pt").is_file()
        and finished_trials(run) < 4
    ]

    def spy(config, logdir):
        state = real(config, logdir)
        if state is not None:
            resumed.append(logdir)
        return state

    monkeypatch.setattr(sweep, "_stopped_state", spy)
    if command == "sweep":  # its runs go on here, where the spy sees them (any --workers)
        argv[argv.index("--workers") + 1] = "1"
    if code:  # (0: it had finished before the signal came)
        resumed_code, message = _quiet([*argv, "--resume"])
        assert resumed_code == 0, message
    for table in tables:
        assert (out / table).read_bytes() == (uninterrupted[command] / table).read_bytes(), table
    assert not (out / checkpointing.STOPPED_NAME).exists()
    assert not glob.glob(str(out / "**" / "batch-*.pt"), recursive=True)  # states dropped
    if stopped_runs:  # a run stopped between trials went on from its checkpoint, not its start
        assert sorted(resumed) == sorted(str(run) for run in stopped_runs)


def test_resume_needs_a_stopped_run_of_the_same_settings(uninterrupted, tmp_path):
    argv, _, _ = COMMANDS["study"]
    code, err = _quiet([*argv, "--out", str(uninterrupted["study"]), "--resume"])
    assert code == 2 and "holds the results of an earlier" in err  # finished: nothing to resume
    out = tmp_path / "out"
    code, err = _quiet([*argv, "--out", str(out), "--resume"])
    assert code == 2 and "holds no stopped `symrl study`" in err
    checkpointing.begin(out, "study", {"recipe": "paper", "sets": 9}, False)  # a stopped one
    code, err = _quiet([*argv, "--out", str(out), "--resume"])
    assert code == 2 and "of other settings" in err and "recipe 'paper' there" in err
    assert len(err.strip().splitlines()) == 1
    code, err = _quiet([*argv, "--out", str(out), "--resume", "--overwrite"])
    assert code == 2 and "give one" in err
    assert _quiet([*argv, "--out", str(out), "--overwrite"])[0] == 0  # afresh
    assert (out / "trials.csv").read_bytes() == (uninterrupted["study"] / "trials.csv").read_bytes()


@pytest.mark.parametrize("sets", [1, 20, 100, 1000])
def test_a_batch_of_many_sets_has_a_file_name_the_system_takes(tmp_path, monkeypatch, sets):
    monkeypatch.setattr(checkpointing, "INTERVAL_S", 0.0)
    keeper = checkpointing.BatchKeeper(tmp_path, {}, list(range(sets)), [])
    other = checkpointing.BatchKeeper(tmp_path, {}, list(range(1, sets + 1)), [])
    assert len(keeper.path.name) < 255 and keeper.path != other.path
    keeper.on_boundary(lambda: {"trials": []})
    assert keeper.path.is_file() and keeper.saved() == {"trials": []}
    assert checkpointing.batch_files(tmp_path) == [keeper.path]
