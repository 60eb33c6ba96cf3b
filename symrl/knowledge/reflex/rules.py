"""The reflex's rule base as data: its output sets, the default sectors, thresholds and rules
of ``docs/explanation/algorithm.md`` section 4, and the grammar one rule is written in.

Kept apart from the module so a config can be read and checked without torch's hot path.
"""

from __future__ import annotations

import math
import re

__all__ = ["OUTPUTS", "SIDES", "parse_rule"]

OUTPUTS: tuple[str, str, str] = ("LEFT", "FORWARD", "RIGHT")
"""The output fuzzy sets, in the order of every activation vector."""

SIDES: tuple[str, str] = ("SIDE_L", "SIDE_R")
"""The crisp turning-side literals a rule may use besides the sectors (``ReflexConfig.side``)."""

HALF_PI = math.pi / 2


def default_sectors() -> dict[str, tuple[int, ...]]:
    return {
        "F": (23, 0, 1),
        "FL": (2, 3, 4),
        "L": (5, 6, 7),
        "FR": (22, 21, 20),
        "R": (19, 18, 17),
    }


def default_near() -> dict[str, tuple[float, float]]:
    return {
        "F": (0.25, 0.70),
        "FL": (0.20, 0.50),
        "FR": (0.20, 0.50),
        "L": (0.10, 0.35),
        "R": (0.10, 0.35),
    }


def default_rules() -> tuple[str, ...]:
    return (
        "F and SIDE_L -> LEFT",
        "F and SIDE_R -> RIGHT",
        "FR and not F -> LEFT",
        "FL and not F -> RIGHT",
        "R -> 0.5 * LEFT",
        "L -> 0.5 * RIGHT",
    )


def default_side() -> tuple[str, ...]:
    return ("FL/FR", "L/R", "goal")


def default_peaks() -> tuple[float, float, float]:
    return (HALF_PI, 0.0, -HALF_PI)


_RULE = re.compile(r"^\s*(?P<lhs>.+?)\s*->\s*(?:(?P<w>[0-9]*\.?[0-9]+)\s*\*\s*)?(?P<set>\w+)\s*$")


def parse_rule(
    text: str, sectors: tuple[str, ...], where: str = "rule"
) -> tuple[list[tuple[str, bool]], int, float]:
    """Read ``"F and not FL -> 0.5 * LEFT"`` into ([(literal, negated)], output index, weight);
    a literal is one of ``sectors`` or of :data:`SIDES`."""
    m = _RULE.match(text) if isinstance(text, str) else None
    if m is None:
        raise ValueError(
            f"{where}: cannot read rule {text!r} (expected e.g. 'F and not FL -> LEFT' "
            "or 'R -> 0.5 * LEFT')"
        )
    if m["set"] not in OUTPUTS:
        raise ValueError(f"{where}: unknown output set {m['set']!r} in {text!r} (sets: {OUTPUTS})")
    weight = float(m["w"]) if m["w"] else 1.0
    if not 0 < weight <= 1:
        raise ValueError(f"{where}: weight must be in (0, 1], got {weight!r} in {text!r}")
    literals = []
    for part in re.split(r"\s+and\s+", m["lhs"]):
        words = part.split()
        negated = len(words) == 2 and words[0] == "not"
        if not (len(words) == 1 or negated) or words[-1] not in (*sectors, *SIDES):
            raise ValueError(
                f"{where}: bad antecedent {part!r} in {text!r} "
                f"(expected a sector or 'not' sector; sectors: {sectors}, sides: {SIDES})"
            )
        literals.append((words[-1], negated))
    return literals, OUTPUTS.index(m["set"]), weight
