"""Test-wide settings: under CI (``CI`` set) Hypothesis draws the same examples every run, so a
green build is reproducible; locally it explores new ones."""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
