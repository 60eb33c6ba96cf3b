"""`symrl study`, `ablate` and `plan` write their files; the same seeds give the same tables."""

from __future__ import annotations

import json

import pytest
import torch

from symrl.cli import main
from symrl.runs import read_trials_csv
from symrl.studies.repeatability import run_study


def _strip(rows):
    return [{k: v for k, v in r.items() if k != "wall_time"} for r in rows]


def test_study_writes_its_files_and_repeats_exactly(tmp_path):
    args = ["study", "reflex_only", "--sets", "2", "--trials", "2", "--workers", "1"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    for name in (
        "trials.csv",
        "table1.md",
        "table1.json",
        "curves.png",
        "trajectories.png",
        "ghosts.png",
    ):
        assert (tmp_path / "a" / name).is_file(), name
    rows = read_trials_csv(tmp_path / "a" / "trials.csv")
    assert [(r["set"], r["trial"], r["seed"]) for r in rows] == [
        (0, 1, 100),
        (0, 2, 100),
        (1, 1, 101),
        (1, 2, 101),
    ]
    table = json.loads((tmp_path / "a" / "table1.json").read_text())
    assert table["sets"] == 2 and table["optimum"]["steps"] == 25
    assert table["neurons"]["mean"] == 0.0  # the reflex alone grows nothing
    assert table["paper"]["steps"] == {"mean": 27.7, "variance": 1.9}  # its world: Table 1
    # same seeds -> the same trials table (wall times aside); the API without figures is cheaper
    run_study("reflex_only", sets=2, trials=2, workers=1, out=tmp_path / "b", figures=False)
    again = read_trials_csv(tmp_path / "b" / "trials.csv")
    assert _strip(again) == _strip(rows)


def test_ablate_writes_summary_and_comparison(tmp_path, capsys):
    out = tmp_path / "abl"
    code = main(
        [
            "ablate",
            "--recipes",
            "reflex_only,paper_literal",
            "--sets",
            "1",
            "--trials",
            "2",
            "--workers",
            "1",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary) >= {"reflex_only", "paper_literal", "_optimum"}
    assert summary["reflex_only"]["neurons_last"]["mean"] == 0.0
    assert summary["paper_literal"]["neurons_last"]["mean"] > 0
    assert (out / "comparison.png").is_file() and (out / "summary.md").is_file()
    assert (out / "paper_literal" / "table1.md").is_file()
    assert "| reflex_only | 1 × 2 |" in capsys.readouterr().out
    # re-running one recipe into the same folder keeps the others' rows
    assert (
        main(
            [
                "ablate",
                "--recipes",
                "reflex_only",
                "--sets",
                "1",
                "--trials",
                "2",
                "--workers",
                "1",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    again = json.loads((out / "summary.json").read_text())
    assert again["paper_literal"] == summary["paper_literal"]
    assert again["reflex_only"]["steps_last5"] == summary["reflex_only"]["steps_last5"]


def test_plan_command_writes_json_and_png(tmp_path):
    assert main(["plan", "--out", str(tmp_path)]) == 0
    plan = json.loads((tmp_path / "plan.json").read_text())
    assert plan["actions"] == 25 and plan["optimum_actions_exact"]
    assert (tmp_path / "plan.png").is_file()


def test_bad_sizes_give_a_clear_error(capsys):
    assert main(["study", "reflex_only", "--sets", "0"]) == 2
    assert "--sets 0: must be >= 1" in capsys.readouterr().err


def test_set_k_of_a_study_is_train_with_seed_plus_k():
    """A study trains its sets as one batch (or a batch per worker); set k is still exactly the
    run ``symrl train RECIPE --seed SEED+k`` makes alone."""
    from symrl.learner.config import load_config
    from symrl.studies.runner import run_sets
    from symrl.train import train

    sets = run_sets("paper_map", sets=3, trials=2, seed=40, progress=False)
    alone = train(load_config("paper_map", ["run.trials=2", "run.seed=42"]), progress=False)
    columns = ("steps", "total_reinforcement", "collisions", "neurons", "temperature", "shielded")
    assert [[t[c] for c in columns] for t in sets[2].rows] == [
        [t[c] for c in columns] for t in alone.trials
    ]
    split = run_sets("paper_map", sets=3, trials=2, seed=40, workers=2, progress=False)
    assert [s.rows for s in split] == [s.rows for s in sets]
    # the controllers come back from the workers as the same tensors
    for a, b in zip(split, sets, strict=True):
        assert a.controller.keys() == b.controller.keys()
        for key, value in a.controller.items():
            assert isinstance(value, torch.Tensor) and torch.equal(value, b.controller[key]), key


def test_a_split_study_counts_every_trial_of_its_workers(capsys):
    """The workers report each finished trial, so the bar of a split study moves while it
    trains and ends at sets x trials."""
    from symrl.studies.runner import run_sets

    run_sets("reflex_only", sets=3, trials=2, seed=40, workers=2, progress=True)
    err = capsys.readouterr().err
    assert "(2 workers)" in err and "6/6" in err


@pytest.mark.parametrize("workers", [1, 2])
def test_the_callers_work_runs_once_while_a_study_waits_on_its_workers(tmp_path, workers):
    """``while_waiting`` (the tables' optimum) runs exactly once: when the first worker is done
    (or after the only batch), and also when every set was found kept and nothing runs."""
    from symrl.studies.runner import run_sets

    calls = []
    for _ in range(2):  # the second run finds every set kept in the folder
        rows = run_sets(
            "reflex_only",
            sets=3,
            trials=1,
            seed=40,
            workers=workers,
            progress=False,
            keep=tmp_path,
            while_waiting=lambda: calls.append(1),
        )
        assert len(rows) == 3
    assert calls == [1, 1]
