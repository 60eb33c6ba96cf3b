"""`symrl ablate --ladder --maps`: every rung on every world in one table and one figure."""

from __future__ import annotations

import json

import pytest

from symrl.cli import main
from symrl.studies.ladder_worlds import (
    ladder_worlds_markdown,
    ladder_worlds_rows,
    write_ladder_worlds,
)


def _rows(steps_per_set, reached=None):
    """Trial rows of one recipe: ``steps_per_set[s][t]`` actions in trial t+1 of set s."""
    out = []
    for s, steps in enumerate(steps_per_set):
        for t, n in enumerate(steps):
            ok = True if reached is None else reached[s][t]
            out.append(
                {
                    "set": s,
                    "trial": t + 1,
                    "steps": n,
                    "total_reinforcement": -n / 4,
                    "reached_goal": ok,
                }
            )
    return out


def test_the_builder_divides_the_last_trials_actions_by_each_worlds_optimum(tmp_path):
    rows = {
        "hailu2001": {
            "reflex_only": _rows([[200] * 6, [40] * 6], [[False] * 6, [True] * 6]),
            "paper_map": _rows([[30] * 6, [20] * 6]),
        },
        "office": {"paper_map": _rows([[50, 50, 50, 50, 60, 60]])},
    }
    entries = ladder_worlds_rows(rows, {"hailu2001": 25, "office": 40})
    by = {(e["world"], e["recipe"]): e for e in entries}
    reflex = by["hailu2001", "reflex_only"]
    assert reflex["actions_last"] == 120.0 and reflex["ratio"] == pytest.approx(120 / 25)
    assert reflex["failed_from"] == 2 and reflex["trials_from"] == 4  # trials 5 and 6
    assert reflex["failed_all"] == 6 and reflex["trials_all"] == 12
    assert reflex["success_last"] == 0.5
    assert by["hailu2001", "paper_map"]["ratio"] == pytest.approx(1.0)
    office = by["office", "paper_map"]
    assert office["actions_last"] == pytest.approx(54.0) and office["ratio"] == 54.0 / 40
    assert office["actions_last_sd"] == 0.0  # one set
    table = ladder_worlds_markdown(entries)
    lines = [line for line in table.splitlines() if line.startswith("| `")]
    assert [line.split("`")[1] for line in lines] == ["hailu2001", "hailu2001", "office"]
    assert "| sensors | `reflex_only` |" in lines[0] and "| 4.80 |" in lines[0]
    assert "| 2 of 4 | 6 of 12 |" in lines[0]
    write_ladder_worlds(tmp_path, entries)
    assert json.loads((tmp_path / "ladder-worlds.json").read_text()) == entries
    assert (tmp_path / "ladder-worlds.md").read_text() == table
    assert (tmp_path / "ladder-worlds.png").stat().st_size > 0


def test_the_ladder_runs_on_each_world_into_one_table(tmp_path, capsys, monkeypatch):
    import symrl.studies.ablation as ablation

    monkeypatch.setattr(ablation, "LADDER", ("reflex_only", "paper_map"))  # two rungs: fast
    out = tmp_path / "worlds"
    argv = [
        "ablate",
        "--ladder",
        "--maps",
        "hailu2001,check/box_room",
        "--sets",
        "1",
        "--trials",
        "2",
        "--workers",
        "1",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    table = (out / "ladder-worlds.md").read_text()
    cells = [line.split("`")[1::2] for line in table.splitlines() if line.startswith("| `")]
    assert cells == [
        ["hailu2001", "reflex_only"],
        ["hailu2001", "paper_map"],
        ["box_room", "reflex_only"],
        ["box_room", "paper_map"],
    ]
    assert (out / "ladder-worlds.png").is_file()
    for world in ("hailu2001", "box_room"):  # each world as `ablate --ladder --map` writes it
        assert (out / world / "ladder.md").is_file()
        assert (out / world / "paper_map" / "trials.csv").is_file()
    assert table in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--maps", "hailu2001,office"], "give it with --ladder"),
        (["--ladder", "--maps", "hailu2001,nowhere"], "--maps 'hailu2001,nowhere': map"),
        (["--ladder", "--maps", "hailu2001,,office"], "an empty name"),
        (["--ladder", "--maps", "office", "--map", "office"], "without --map"),
        (["--ladder", "--maps", "hailu2001,hailu2001"], "both named 'hailu2001'"),
    ],
)
def test_bad_maps_are_one_line(argv, says, tmp_path, capsys):
    assert main(["ablate", *argv, "--out", str(tmp_path / "a")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and says in err
    assert not (tmp_path / "a").exists()
