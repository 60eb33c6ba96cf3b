"""Fixtures of the learner tests."""

from __future__ import annotations

import pytest

from symrl.learner.config import LearnerConfig
from symrl.learner.policy import MixtureOfExpertsPolicy


@pytest.fixture
def make_policy():
    def _make(**overrides) -> MixtureOfExpertsPolicy:
        return MixtureOfExpertsPolicy(LearnerConfig(**overrides), world="hailu2001", seed=0)

    return _make
