"""Every input of the bad-input corpus (``corpus.yaml``: CLI flags, overrides, recipes, maps,
checkpoints, the env API) is refused with one line holding its expected words: no traceback,
nothing silently accepted, no hang. Each runs in this process (``harness.run_case``)."""

from __future__ import annotations

import pytest
from harness import load_cases, make_fixtures, run_case

import symrl.train

CASES = load_cases()


@pytest.fixture(scope="module")
def places(tmp_path_factory):
    return make_fixtures(tmp_path_factory.mktemp("fixtures"))


def test_the_corpus_is_broad():
    sections = {c["section"] for c in CASES}
    assert len(CASES) >= 300 and sections == {
        "cli",
        "overrides",
        "recipes",
        "maps",
        "checkpoints",
        "env",
    }


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_bad_input_is_refused_in_one_line(case, places, tmp_path, monkeypatch):
    monkeypatch.setattr(symrl.train, "_available_memory", lambda: 16 << 30)
    outcome = run_case(case, places, tmp_path)
    assert outcome.kind == "one-line", outcome.text
    assert case["expect"] in outcome.text, outcome.text
