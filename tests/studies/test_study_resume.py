"""A study re-run into the same folder with the same settings keeps its finished sets (they are
not trained again) and gives the same table; other settings run every set again."""

from __future__ import annotations

import symrl.studies.runner as runner
from symrl.runs import read_trials_csv
from symrl.studies.repeatability import run_study


def _study(out, trials=1):
    return run_study(
        "paper_map",
        sets=2,
        trials=trials,
        seed=40,
        out=out,
        figures=False,
        starts=[(0.0, 0.5, 0.0)],
        progress=False,
    )


def test_finished_sets_are_kept_and_skipped(tmp_path, monkeypatch):
    out = tmp_path / "study"
    first = _study(out)
    table = read_trials_csv(out / "trials.csv")
    assert sorted(p.name for p in (out / "sets").iterdir()) == ["set-000.pt", "set-001.pt"]
    (out / "sets" / "set-001.pt").unlink()  # as if the study stopped before set 1 was done
    trained = []
    real = runner._run_batch

    def spy(data, indices, seeds, starts, progress, **kwargs):
        trained.append(list(seeds))
        return real(data, indices, seeds, starts, progress, **kwargs)

    monkeypatch.setattr(runner, "_run_batch", spy)
    again = _study(out)
    assert trained == [[41]]  # only the missing set ran
    assert read_trials_csv(out / "trials.csv") == table
    assert [s.evaluations for s in again.sets] == [s.evaluations for s in first.sets]
    trained.clear()
    _study(out)
    assert trained == []  # everything kept
    _study(out, trials=2)  # other settings: every set again
    assert trained == [[40, 41]]
