"""``symrl sweep``: every run of the grid is the run ``symrl train`` writes alone, a re-run keeps
the finished runs, the merged table covers every recipe and map, bad inputs are one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import symrl.studies.sweep as sweep
import symrl.world
from symrl.cli import main
from symrl.runs import read_trials_csv

GRID = ["--recipes", "paper,reflex_only", "--seeds", "40-41", "--trials", "2"]
RUNS = [
    "paper__hailu2001__s40",
    "paper__hailu2001__s41",
    "reflex_only__hailu2001__s40",
    "reflex_only__hailu2001__s41",
]
TWO_DOORS_FILE = str(Path(symrl.world.__file__).parent / "maps" / "two_doors.yaml")


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "out"
    assert main(["sweep", *GRID, "--out", str(out)]) == 0
    return out


def test_every_run_folder_and_the_merged_table(swept):
    assert sorted(p.name for p in (swept / "runs").iterdir()) == RUNS
    for name in RUNS:
        folder = swept / "runs" / name
        for part in ("config.yaml", "trials.csv", "checkpoint.pt", "trajectory.png", "tb"):
            assert (folder / part).exists(), (name, part)
        assert len(read_trials_csv(folder / "trials.csv")) == 2
    assert (swept / "comparison.png").stat().st_size > 0
    table = (swept / "summary.md").read_text()
    assert "| paper | hailu2001 | 2 | 2 |" in table
    assert "| reflex_only | hailu2001 | 2 | 2 |" in table
    data = json.loads((swept / "summary.json").read_text())
    assert [(r["recipe"], r["map"], r["seeds"]) for r in data["results"]] == [
        ("paper", "hailu2001", [40, 41]),
        ("reflex_only", "hailu2001", [40, 41]),
    ]
    for r in data["results"]:
        assert {
            "steps_last5",
            "total_reinforcement_last5",
            "collisions_all_trials",
            "success_last5",
        } <= set(r)
        assert len(r["total_reinforcement_last5"]["ci95"]) == 2


@pytest.mark.parametrize(("recipe", "seed"), [("paper", 41), ("reflex_only", 40)])
def test_a_run_is_symrl_train_alone(swept, tmp_path, recipe, seed):
    alone = tmp_path / "alone"
    argv = ["train", recipe, "--seed", str(seed), "--trials", "2", "--logdir", str(alone)]
    assert main(argv) == 0
    ours = read_trials_csv(swept / "runs" / f"{recipe}__hailu2001__s{seed}" / "trials.csv")
    assert ours == read_trials_csv(alone / "trials.csv")


def test_rerun_keeps_finished_runs(swept, monkeypatch, capsys):
    table = (swept / "summary.md").read_text()
    trained: list[str] = []
    real = sweep.train_run

    def spy(config, logdir):
        trained.append(logdir)
        return real(config, logdir)

    monkeypatch.setattr(sweep, "train_run", spy)
    assert main(["sweep", *GRID, "--out", str(swept)]) == 0
    assert trained == []
    assert "4 already finished" in capsys.readouterr().out
    assert (swept / "summary.md").read_text() == table
    # an unfinished run (one trial of two) is run again, the others are kept
    csv_path = swept / "runs" / RUNS[1] / "trials.csv"
    full = csv_path.read_text()
    csv_path.write_text("".join(full.splitlines(keepends=True)[:2]))
    assert main(["sweep", *GRID, "--out", str(swept)]) == 0
    assert [p.rsplit("/", 1)[-1] for p in trained] == [RUNS[1]]
    assert csv_path.read_text() == full


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--recipes", "paper_map", "--seeds", "5-2"], "--seeds '5-2'"),
        (["--recipes", "paper_map", "--seeds", "a-b"], "--seeds 'a-b'"),
        (["--recipes", "nosuch", "--seeds", "1"], "nosuch"),
        (["--recipes", "paper_map", "--seeds", "1", "--maps", "nosuch"], "nosuch"),
        (["--recipes", ",", "--seeds", "1"], "--recipes"),
        (["--recipes", "paper_map", "--seeds", "1", "--trials", "0"], "--trials 0"),
        (["--recipes", "paper_map", "--seeds", "1", "--workers", "0"], "--workers 0"),
        (["--recipes", "paper_map", "--seeds", "1", "update.nosuch=1"], "nosuch"),
        (
            ["--recipes", "paper_map", "--seeds", "1", "--maps", f"two_doors,{TWO_DOORS_FILE}"],
            "share the folder",
        ),
    ],
)
def test_bad_inputs_are_one_line_errors(tmp_path, capsys, argv, message):
    out = tmp_path / "out"
    assert main(["sweep", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("symrl sweep: error:") and message in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_ray_missing_is_one_line(tmp_path, capsys, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_ray(name, *args, **kwargs):
        if name == "ray" or name.startswith("ray."):
            raise ImportError("No module named 'ray'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ray)
    argv = [
        "sweep",
        "--recipes",
        "paper_map",
        "--seeds",
        "1",
        "--backend",
        "ray",
        "--out",
        str(tmp_path / "out"),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == 'symrl sweep: error: the ray backend needs Ray: pip install "symrl[ray]"'


def test_ray_backend_gives_the_local_tables(swept, tmp_path):
    """The Ray backend on a local Ray cluster writes the same trial tables as the local pool.

    Skipped when Ray is not importable: CI installs ``symrl[dev]`` only, not the optional
    ``symrl[ray]`` extra, so this test runs where Ray is installed (``pip install
    "symrl[ray]"``)."""
    pytest.importorskip("ray")
    out = tmp_path / "ray"
    argv = [
        "sweep",
        "--recipes",
        "reflex_only",
        "--seeds",
        "40-41",
        "--trials",
        "2",
        "--backend",
        "ray",
        "--workers",
        "2",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    for seed in (40, 41):
        name = f"reflex_only__hailu2001__s{seed}"
        assert read_trials_csv(out / "runs" / name / "trials.csv") == read_trials_csv(
            swept / "runs" / name / "trials.csv"
        )
