"""A closed terminal (SIGHUP) stops `symrl train` as Ctrl-C and SIGTERM do: with its stop
message and its finished trials saved."""

from __future__ import annotations

import os
import signal

from symrl.cli import main
from symrl.runs import read_trials_csv


def test_sighup_stops_train_with_its_message(tmp_path, capsys, monkeypatch):
    import symrl.runs as runs_module

    real = runs_module.RunWriter.trial

    def trial_then_hangup(self, record, last):
        real(self, record, last)
        if record["trial"] == 1:
            os.kill(os.getpid(), signal.SIGHUP)

    monkeypatch.setattr(runs_module.RunWriter, "trial", trial_then_hangup)
    run = tmp_path / "run"
    code = main(["train", "reflex_only", "--trials", "3", "--logdir", str(run)])
    assert code == 128 + signal.SIGHUP
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("symrl train: stopped by SIGHUP after 1 of 3 finished trials")
    assert len(read_trials_csv(run / "trials.csv")) == 1
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_DFL  # given back after the command


def test_version():
    import pytest

    import symrl

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and symrl.__version__
