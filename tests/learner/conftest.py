"""Shared helpers of the learner tests: policies on the paper's map, hand-made observations."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
