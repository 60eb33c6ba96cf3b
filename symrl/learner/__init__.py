"""The learner: growing RBF experts, sub-goal options, the mixture-of-experts policy (acts), the
TESEO update (learns), configs.

Names are imported lazily so ``from symrl.learner import load_config`` does not pay for
importing TorchRL (several seconds); the policy and the update load it on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ConfigError": "config",
    "RunConfig": "config",
    "EnvConfig": "config",
    "GateConfig": "config",
    "ExpertsConfig": "config",
    "UpdateConfig": "config",
    "OptionsConfig": "config",
    "OptionCriticConfig": "config",
    "CrossingsConfig": "config",
    "ShieldSection": "config",
    "RunSection": "config",
    "load_config": "config",
    "config_from_dict": "config",
    "config_to_dict": "config",
    "ExpertBank": "experts",
    "SubgoalOptions": "options",
    "MixtureOfExpertsPolicy": "policy",
    "Perception": "policy",
    "TeseoLoss": "loss",
    "TeseoUpdate": "update",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"symrl.learner.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'symrl.learner' has no attribute {name!r}")
