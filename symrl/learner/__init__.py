"""The learner: growing RBF experts, the mixture-of-experts policy, the TESEO update, configs.

Names are imported lazily so ``from symrl.learner import load_config`` does not pay for
importing TorchRL (several seconds); the policy and the loss load it on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ConfigError": "config",
    "LearnerConfig": "config",
    "EnvConfig": "config",
    "RunConfig": "config",
    "load_config": "config",
    "GrowingRBFExpert": "experts",
    "MixtureOfExpertsPolicy": "policy",
    "Observation": "policy",
    "TeseoLoss": "loss",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"symrl.learner.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'symrl.learner' has no attribute {name!r}")
