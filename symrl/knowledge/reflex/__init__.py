"""The fuzzy reflex of Hailu (2001) section 6.2 as a batched torch module.

Two fuzzy behaviours vote on three output sets (LEFT, FORWARD, RIGHT): obstacle avoidance
reads the sonars, goal following reads the signed goal angle. Their activation vectors are
fused with constant desirabilities (Eq. 5) and defuzzified to one crisp turning angle.
The paper gives the architecture but not the rules; the rule base here is the reconstruction
of ``docs/explanation/algorithm.md`` section 4, with its two crucial details. The FL/FR
rules are guarded
by "and not F", and a blocked front turns to ONE side, the crisp turning side ``SIDE_L`` /
``SIDE_R`` (the freer side, else the goal's side): otherwise a robot facing a concave corner
gets LEFT = RIGHT, the votes cancel into "forward", and it rams the corner. The rule base is
mirror-symmetric: mirroring the sonar ring (ray k <-> ray -k) and negating the goal angle
negates the output exactly; no side is preferred. The whole reflex is a few tensor operations
over any leading batch shape (fuzzy libraries that take milliseconds per inference are what
we avoid).

The package, by job: :mod:`.rules` (the rule base as data and its grammar), :mod:`.config`
(:class:`ReflexConfig` and its checks), :mod:`.compiled` (the rule base compiled for the hot
paths), :mod:`.module` (:class:`FuzzyReflex`, the batched torch module) and :mod:`.fast` (its
float64 CPU paths on numpy and Python floats).
"""

from symrl.knowledge.reflex.config import ReflexConfig
from symrl.knowledge.reflex.fast import check_finite
from symrl.knowledge.reflex.module import FuzzyReflex
from symrl.knowledge.reflex.rules import OUTPUTS, SIDES, parse_rule

__all__ = ["OUTPUTS", "SIDES", "ReflexConfig", "FuzzyReflex", "check_finite", "parse_rule"]
