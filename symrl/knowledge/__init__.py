"""The paper's two pieces of prior knowledge: the region mapper and the fuzzy reflex.

Both are plain ``torch.nn.Module`` s that know nothing of TorchRL: the learner wraps them. They
are imported when first asked for (``from symrl.knowledge import FuzzyReflex``): the planner's
modules beside them need no torch, and importing it took two of the seconds of a `symrl plan`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from symrl.knowledge.reflex import OUTPUTS, FuzzyReflex, ReflexConfig
    from symrl.knowledge.regions import RegionMapper

__all__ = ["OUTPUTS", "FuzzyReflex", "ReflexConfig", "RegionMapper"]

_HOMES = {
    "OUTPUTS": "symrl.knowledge.reflex",
    "FuzzyReflex": "symrl.knowledge.reflex",
    "ReflexConfig": "symrl.knowledge.reflex",
    "RegionMapper": "symrl.knowledge.regions",
}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(home), name)
