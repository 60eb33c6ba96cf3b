"""A closed terminal (SIGHUP) stops `symrl train` as Ctrl-C and SIGTERM do: with its stop
message and its finished trials saved."""

from __future__ import annotations

import os
import signal

import pytest

from symrl.cli import main
from symrl.runs import read_trials_csv


@pytest.fixture
def sighup():
    """Sets SIGHUP's handler for a test, as a terminal (SIG_DFL) or ``nohup`` (SIG_IGN) leaves
    it for the command, and gives the one before back afterwards."""
    before = signal.getsignal(signal.SIGHUP)
    yield lambda handler: signal.signal(signal.SIGHUP, handler)
    signal.signal(signal.SIGHUP, before)


def _hang_up_after_the_first_trial(monkeypatch) -> None:
    import symrl.runs as runs_module

    real = runs_module.RunWriter.trial

    def trial_then_hangup(self, record, last):
        real(self, record, last)
        if record["trial"] == 1:
            os.kill(os.getpid(), signal.SIGHUP)

    monkeypatch.setattr(runs_module.RunWriter, "trial", trial_then_hangup)


def test_sighup_stops_train_with_its_message(tmp_path, capsys, monkeypatch, sighup):
    sighup(signal.SIG_DFL)
    _hang_up_after_the_first_trial(monkeypatch)
    run = tmp_path / "run"
    code = main(["train", "reflex_only", "--trials", "3", "--logdir", str(run)])
    assert code == 128 + signal.SIGHUP
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("symrl train: stopped by SIGHUP after 1 of 3 finished trials")
    assert len(read_trials_csv(run / "trials.csv")) == 1
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_DFL  # given back after the command


def test_a_run_started_under_nohup_survives_a_hangup(tmp_path, monkeypatch, sighup):
    """``nohup`` starts the command with SIGHUP ignored: a closed terminal must not stop it."""
    sighup(signal.SIG_IGN)
    _hang_up_after_the_first_trial(monkeypatch)
    run = tmp_path / "run"
    assert main(["train", "reflex_only", "--trials", "3", "--logdir", str(run)]) == 0
    assert len(read_trials_csv(run / "trials.csv")) == 3
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN


def test_version():
    import symrl

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and symrl.__version__
