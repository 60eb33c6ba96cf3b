"""The learner tests import their hand-made observations and transitions from
``learner_helpers`` beside them."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
