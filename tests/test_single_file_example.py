"""The single-file learner (``examples/teseo_paper.py``) is the library's ``paper_literal``:
run on one seed, both write the same trials.csv, byte for byte. Any change to the learner's
arithmetic, its random draws or its logging that one side makes and the other does not fails
here."""

from __future__ import annotations

import csv
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "teseo_paper.py"


def _env() -> dict[str, str]:
    """The environment for a child Python that imports this checkout's symrl."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    env["MPLBACKEND"] = "Agg"
    return env


def _run(command: list[str], cwd: Path) -> None:
    proc = subprocess.run(command, cwd=cwd, env=_env(), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("trials", "budget"),
    [
        (3, None),  # the recipe as it is: two better successes (actions replaced), one not
        (4, 45),  # a budget some trials hit: a failed trial, a success on the last action
    ],
)
def test_single_file_learner_writes_the_library_trial_table(
    tmp_path: Path, trials: int, budget: int | None
) -> None:
    seed = 0
    library = [
        sys.executable,
        "-m",
        "symrl",
        "train",
        "paper_literal",
        "--trials",
        str(trials),
        "--seed",
        str(seed),
        "--logdir",
        str(tmp_path / "run"),
    ]
    single = [
        sys.executable,
        str(EXAMPLE),
        "--seed",
        str(seed),
        "--trials",
        str(trials),
        "--out",
        str(tmp_path / "single.csv"),
    ]
    if budget is not None:
        library.append(f"env.max_actions={budget}")
        single += ["--max-actions", str(budget)]
    _run(library, tmp_path)
    _run(single, tmp_path)
    expected = (tmp_path / "run" / "trials.csv").read_bytes()
    got = (tmp_path / "single.csv").read_bytes()
    rows = list(csv.DictReader(io.StringIO(expected.decode())))
    assert len(rows) == trials, rows
    # each case holds what it is meant to cover
    assert {r["improved"] for r in rows} == {"True", "False"}, rows
    if budget is not None:
        assert any(r["reached_goal"] == "False" and r["steps"] == str(budget) for r in rows)
        assert any(r["reached_goal"] == "True" and r["steps"] == str(budget) for r in rows)
    assert got == expected, (got.decode(), expected.decode())
