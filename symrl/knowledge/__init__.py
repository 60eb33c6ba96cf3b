"""The paper's two pieces of prior knowledge: the region mapper and the fuzzy reflex.

Both are plain ``torch.nn.Module`` s that know nothing of TorchRL: the learner wraps them.
"""

from symrl.knowledge.reflex import OUTPUTS, FuzzyReflex, ReflexConfig
from symrl.knowledge.regions import RegionMapper

__all__ = ["OUTPUTS", "FuzzyReflex", "ReflexConfig", "RegionMapper"]
