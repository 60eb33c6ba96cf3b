"""Poses on the command line: ``--start X,Y,HEADING_DEG`` read, printed, and named in the
error of a start the world refuses."""

from __future__ import annotations

import argparse
import contextlib
import math
from collections.abc import Iterator

START_HELP = (
    "start pose X,Y,HEADING_DEG (metres, metres, degrees; heading 0 if left out; negative "
    "values as --start -1.4,0,0 or --start=-1.4,0,0); default: the map's start"
)
MAX_COORD = 1e4
"""Largest |X|, |Y| of a pose given on the command line (metres), as in a map file."""


def parse_pose(text: str) -> tuple[float, float, float]:
    """Read ``X,Y,HEADING_DEG`` (metres, metres, degrees) or ``X,Y`` (heading 0); returns
    ``(x, y, heading)`` with the heading in radians, as the env and the API take it."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected X,Y[,HEADING_DEG] as finite numbers (metres, metres, degrees), "
            "e.g. 0,0.5,90"
        )
    if len(values) == 2:
        values.append(0.0)
    if max(abs(values[0]), abs(values[1])) > MAX_COORD or abs(values[2]) > 360:
        raise argparse.ArgumentTypeError(
            f"{text!r}: X and Y must lie within +-{MAX_COORD:g} m and HEADING_DEG within "
            "+-360 degrees"
        )
    return values[0], values[1], math.radians(values[2])


def format_pose(pose) -> str:
    """A pose ``(x, y, heading in radians)`` as printed: ``(x, y, heading deg)``."""
    x, y, h = (float(v) for v in pose)
    return f"({x:g}, {y:g}, {math.degrees(h):.0f} deg)"


@contextlib.contextmanager
def naming_start(start) -> Iterator[None]:
    """A start pose the world refuses (in a wall, too near one) is an error of ``--start``."""
    try:
        yield
    except ValueError as err:
        if start is None or "pose" not in str(err):
            raise
        x, y, h = start
        raise ValueError(f"--start {x:g},{y:g},{math.degrees(h):g}: {err}") from None
