"""The how-to's worked example (docs/how-to/add-a-learner.md): the page shows
``examples/hill_climbing_reflex.py`` as it is, and that learner trains through symrl's loop."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "hill_climbing_reflex.py"
PAGE = ROOT / "docs" / "how-to" / "add-a-learner.md"


def _example():
    spec = importlib.util.spec_from_file_location("hill_climbing_reflex", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_page_shows_the_example_file_as_it_is():
    page = PAGE.read_text()
    block = page.split("```python\n", 1)[1].split("```\n", 1)[0]
    assert block == EXAMPLE.read_text()


def test_the_example_learner_trains_through_the_loop():
    from symrl.agent import Agent

    example = _example()
    rows = example.train(trials=2, seed=0, robots=2, progress=False)
    assert [[r["trial"] for r in robot] for robot in rows] == [[1, 2], [1, 2]]
    assert all(-1.0 <= r["correction"] <= 1.0 for robot in rows for r in robot)
    assert "mean_abs_td_error" not in rows[0][0]
    assert rows[0][0]["correction"] == 0.0  # the first trial drives the reflex alone
    config = example.load_config("sac", ["run.trials=2"])
    assert isinstance(example.HillClimbingReflex(config, 2), Agent)


def test_the_example_learner_keeps_a_better_correction_and_goes_on_from_its_state():
    import numpy as np

    example = _example()
    agent = example.HillClimbingReflex(
        example.load_config("sac", ["run.trials=2"]), robots=2, seed=1
    )
    rows = np.array([0, 1])
    agent.end_trials(rows, [{"total_reinforcement": -10.0}] * 2, np.array([True, True]))
    tried = agent.correction.clone()
    state = agent.state_dict()
    extras = agent.end_trials(
        rows, [{"total_reinforcement": -5.0}, {"total_reinforcement": -20.0}], np.ones(2, bool)
    )
    assert extras[0]["correction"] == round(float(tried[0]), 4)  # better: kept
    assert extras[1]["correction"] == 0.0  # worse: back to the best
    again = example.HillClimbingReflex(
        example.load_config("sac", ["run.trials=2"]), robots=2, seed=1
    )
    again.load_state_dict(state)
    assert (
        again.end_trials(
            rows, [{"total_reinforcement": -5.0}, {"total_reinforcement": -20.0}], np.ones(2, bool)
        )
        == extras
    )
