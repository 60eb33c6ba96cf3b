"""`symrl ablate --changes-of`: each setting a recipe changes, put back in turn, and its paired
difference over the sets."""

from __future__ import annotations

import json

import pytest

from symrl.cli import main
from symrl.learner.config import load_config
from symrl.studies.ablation import Variant, changes_markdown, changes_of
from symrl.studies.ablation_variants import leaves

RECIPE = """\
knowledge: regions
reflex:
  d_a: 0.5
  peaks: [0.5, 0.0, -0.5]
  near: {FL: [0.1, 0.3]}
shield:
  enabled: true
run:
  trials: 3
"""


@pytest.fixture
def recipe(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(RECIPE)
    return path


def test_each_changed_setting_is_put_back_alone(recipe):
    variants = changes_of(str(recipe))
    names = [v.name for v in variants]
    assert names[0] == "mine" and variants[0].overrides == ()
    assert names[-1] == "mine-experts-off"
    # run.trials is the budget, not a change; reflex.near is one setting
    assert set(names[1:-1]) == {
        "mine-without-reflex.d_a",
        "mine-without-reflex.peaks",
        "mine-without-reflex.near",
        "mine-without-shield.enabled",
    }
    literal, mine = leaves(load_config("paper_literal")), leaves(load_config(str(recipe)))
    for v in variants[1:-1]:
        key = v.name.removeprefix("mine-without-")
        got = leaves(load_config(str(recipe), list(v.overrides)))
        assert got[key] == literal[key]  # this setting is the base recipe's again
        assert {k: x for k, x in got.items() if k != key} == {
            k: x for k, x in mine.items() if k != key
        }  # every other setting is the recipe's
    near = next(v for v in variants if v.name.endswith("reflex.near"))
    assert near.change == "reflex.near: {FL: [0.1, 0.3]} -> {FL: [0.2, 0.5]}"  # only FL differs
    off = load_config(str(recipe), list(variants[-1].overrides))
    assert off.experts.learning is False


def test_the_base_recipe_has_no_changes_of_its_own():
    assert [v.name for v in changes_of("paper_literal")] == [
        "paper_literal",
        "paper_literal-experts-off",
    ]
    assert [v.name for v in changes_of("reflex_only", base="reflex_only")] == ["reflex_only"]


def _rows(totals_by_set, steps=27):
    return [
        {
            "set": s,
            "trial": t,
            "total_reinforcement": total,
            "steps": steps,
            "collisions": 0,
            "neurons": 10,
            "reached_goal": True,
        }
        for s, totals in totals_by_set.items()
        for t, total in enumerate(totals, 1)
    ]


def test_changes_table_gives_the_paired_difference_per_setting():
    full, minus = Variant("r", "r"), Variant("r-without-x", "r", ("x=1",), "x: 0 -> 1")
    rows = {
        "r": _rows({0: [-10, -8], 1: [-12, -6]}),  # last 1: -8, -6
        "r-without-x": _rows({0: [-10, -9], 1: [-12, -10]}),  # last 1: -9, -10
    }
    md = changes_markdown([full, minus], rows, last=1)
    lines = md.splitlines()
    assert lines[2].startswith("| r | - | -7.00 | - | -9.00 | - |")
    # last trial: the setting is worth +1 and +4 on the two sets, +2.50 ± 1.50 (standard
    # error); over both trials +0.5 and +2, +1.25 ± 0.75
    assert lines[3].startswith(
        "| r-without-x | x: 0 -> 1 | -9.50 | +2.50 ± 1.50 | -10.25 | +1.25 ± 0.75 | 27.0 |"
    )


def test_ablate_changes_of_writes_one_run_per_setting(recipe, tmp_path, capsys):
    out = tmp_path / "abl"
    assert (
        main(
            [
                "ablate",
                "--changes-of",
                str(recipe),
                "--sets",
                "2",
                "--trials",
                "2",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    summary = json.loads((out / "summary.json").read_text())
    names = [v.name for v in changes_of(str(recipe))]
    assert [k for k in summary if not k.startswith("_")] == names
    for name in names:
        assert (out / name / "trials.csv").is_file()
    table = (out / "changes.md").read_text()
    assert table.count("\n") == len(names) + 2  # header, rule, one row per variant
    assert "| mine-without-shield.enabled | shield.enabled: true -> false |" in table
    assert json.loads((out / "mine-without-reflex.d_a" / "table1.json").read_text())[
        "overrides"
    ] == ["reflex.d_a=0.7"]
    assert "Δ last 5 (paired)" in capsys.readouterr().out


def test_a_setting_that_cannot_be_put_back_alone_has_no_row():
    """``paper`` takes its sub-goals from the region rules; ``options.source=map`` alone would
    need the map rung, so it is no row (``options.enabled=false`` is)."""
    names = [v.name for v in changes_of("paper")]
    assert "paper-without-options.source" not in names
    assert "paper-without-options.enabled" in names


def test_the_ladder_runs_each_rungs_recipe_on_the_same_seeds(tmp_path, capsys):
    out = tmp_path / "ladder"
    argv = [
        "ablate",
        "--ladder",
        "--sets",
        "1",
        "--trials",
        "1",
        "--workers",
        "1",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    table = (out / "ladder.md").read_text()
    rows = [line for line in table.splitlines() if line.startswith("| ") and "`" in line]
    assert [r.split("|")[1].strip() for r in rows] == [
        "sensors",
        "regions",
        "regions",
        "passages",
        "map",
    ]
    assert [r.split("`")[1] for r in rows] == [
        "reflex_only",
        "paper_literal",
        "paper",
        "paper_passages",
        "paper_map",
    ]
    assert "real robot" in table and table in capsys.readouterr().out
    assert main(["ablate", "--ladder", "--recipes", "paper", "--out", str(out)]) != 0
    assert "--ladder runs its own recipes" in capsys.readouterr().err
