"""Every shipped ``symrl`` command runs from its defaults (at tiny budgets, in a fresh folder)
and writes what it says, so a renamed key cannot break a command unseen. ``generalise`` has its
own test beside its study."""

from __future__ import annotations

import pytest

from symrl.cli import build_parser, main


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the default output folders land here
    return tmp_path


def _run(argv, capsys):
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return captured.out


def test_drive(here, capsys):
    out = _run(["drive"], capsys)
    assert "reached goal" in out
    assert (here / "results/drive/path.png").is_file()
    assert (here / "results/drive/trial.json").is_file()
    assert main(["drive"]) == 2  # not silently over the first
    assert "--overwrite" in capsys.readouterr().err
    _run(["drive", "--overwrite", "--start", "-0.5,0.5,-90"], capsys)


def test_train_then_evaluate_and_resume(here, capsys):
    out = _run(["train", "paper", "--trials", "2"], capsys)
    assert "paper (seed 0): 2 trials" in out
    (run,) = (here / "runs").iterdir()
    assert {p.name for p in run.iterdir()} >= {
        "config.yaml",
        "trials.csv",
        "checkpoint.pt",
        "trajectory.png",
        "tb",
    }
    assert "greedy trial" in _run(["evaluate", str(run / "checkpoint.pt")], capsys)
    assert (run / "evaluate.png").is_file()
    assert "3 trials" in _run(["train", "--resume", str(run), "--trials", "3"], capsys)


def test_study(here, capsys):
    out = _run(["study", "paper", "--sets", "2", "--trials", "2", "--workers", "1"], capsys)
    assert "wall time" in out and (here / "results/study-paper/table1.json").is_file()


def test_ablate(here, capsys):
    _run(["ablate", "--sets", "1", "--trials", "1", "--workers", "1"], capsys)
    assert (here / "results/ablate/summary.md").is_file()


def test_plan(here, capsys):
    assert "shortest path" in _run(["plan"], capsys)
    assert (here / "results/plan/plan.json").is_file()


@pytest.mark.parametrize("algorithm", ["sac", "ppo"])
def test_baseline(algorithm, here, capsys):
    _run(["baseline", algorithm, "--episodes", "1"], capsys)
    assert list((here / "results").glob(f"baseline-{algorithm}*/seed-100/trials.csv"))


def test_sweep(here, capsys):
    _run(
        ["sweep", "--recipes", "paper", "--seeds", "1", "--trials", "1", "--out", "results/sweep"],
        capsys,
    )
    assert (here / "results/sweep/summary.md").is_file()


def test_every_option_of_every_command_has_help():
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "command"]
    for name, command in sub.choices.items():
        for action in command._actions:
            if action.dest != "help":
                assert action.help, f"symrl {name} {action.option_strings or action.dest}"
