"""symrl: symbolic structures in numeric reinforcement (Hailu, 2001) with PyTorch and TorchRL.

Importing symrl registers the Gymnasium env ``symrl/Hailu2001-v0``. Heavy modules (torch,
torchrl) are imported only by the parts that need them, so ``import symrl`` stays cheap.
``symrl.__version__`` comes from the installed package's metadata; ``symrl.provenance()`` reports
it with the code revision and the versions of the main libraries (see :mod:`symrl.about`).
"""

import gymnasium

from symrl.about import __version__, provenance

ENV_ID = "symrl/Hailu2001-v0"

if ENV_ID not in gymnasium.registry:
    # The env truncates itself at `max_actions` (200 by default), so no TimeLimit wrapper.
    gymnasium.register(id=ENV_ID, entry_point="symrl.world.env:Hailu2001Env")

__all__ = ["ENV_ID", "__version__", "provenance"]
