"""A map's region partition (paper section 6.1): its rule types, read from the map file and
checked so that every rule can fire.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np
from shapely.geometry import Polygon, box

from symrl.world.map_fields import MapError, read_number, short_repr

__all__ = ["MAX_REGIONS", "Condition", "RegionRule", "RegionSpec", "check_regions", "read_regions"]

MAX_REGIONS = 64
"""Most regions a map may name (the shipped maps name at most 7)."""
_COND = re.compile(r"^\s*([xy])\s*([<>])\s*([A-Za-z_][A-Za-z0-9_]*)\s*$")


@dataclass(frozen=True)
class Condition:
    """``axis op line``: e.g. ``x > l3`` is axis 0, sign +1, the x-intercept of l3."""

    axis: int  # 0 for x, 1 for y
    greater: bool  # True for ">", False for "<"
    threshold: float
    text: str


@dataclass(frozen=True)
class RegionRule:
    region: str
    conditions: tuple[Condition, ...]

    def bounds(self, world_bounds: tuple[float, float, float, float]) -> list[list[float]]:
        """The axis-aligned box ``[[x_lo, x_hi], [y_lo, y_hi]]`` its conditions allow inside the
        map's bounds widened by 1 m (empty when a lower end is not below its upper end)."""
        xmin, xmax, ymin, ymax = world_bounds
        lo_hi = [[xmin - 1.0, xmax + 1.0], [ymin - 1.0, ymax + 1.0]]
        for c in self.conditions:
            bound = lo_hi[c.axis]
            if c.greater:
                bound[0] = max(bound[0], c.threshold)
            else:
                bound[1] = min(bound[1], c.threshold)
        return lo_hi


@dataclass(frozen=True)
class RegionSpec:
    """The symbolic partition (paper section 6.1): named lines and first-match rules."""

    names: tuple[str, ...]
    lines: dict[str, tuple[str, float]]  # name -> ("x" | "y", intercept)
    rules: tuple[RegionRule, ...]

    def region_of(self, x: float, y: float) -> str:
        """Reference implementation of the rules for one point (the torch module batches
        this)."""
        return self.regions_of(np.array([x], dtype=np.float64), np.array([y], dtype=np.float64))[0]

    def regions_of(self, x: np.ndarray, y: np.ndarray) -> list[str]:
        """The region of many points (float64 arrays of one shape, flattened): first-match
        rules, each rule's strict comparisons on all points at once (thousands of points when
        the sub-goal table scans the region lines)."""
        xy = (np.asarray(x, dtype=np.float64).ravel(), np.asarray(y, dtype=np.float64).ravel())
        found = np.full(len(xy[0]), -1)
        for i, rule in enumerate(self.rules):
            holds = found < 0
            for c in rule.conditions:
                v = xy[c.axis]
                holds &= v > c.threshold if c.greater else v < c.threshold
            found[holds] = i
        if (found < 0).any():
            j = int(np.argmax(found < 0))
            raise MapError(
                f"regions.rules: no rule matches the pose ({float(xy[0][j])}, {float(xy[1][j])}); "
                "add a default rule"
            )
        return [self.rules[i].region for i in found.tolist()]


def read_regions(value: Any) -> RegionSpec:
    """The map's ``regions`` mapping ``{names, lines, rules}`` as a :class:`RegionSpec`."""
    if not isinstance(value, dict):
        raise MapError(
            "field 'regions' must be 'auto' or a mapping {names, lines, rules}, "
            f"got {short_repr(value)}"
        )
    for key in ("names", "lines", "rules"):
        if key not in value:
            raise MapError(f"field 'regions' is missing {key!r}")
    extra = set(value) - {"names", "lines", "rules"}
    if extra:
        raise MapError(f"field 'regions' has unknown key(s) {sorted(extra)}")
    names = _read_names(value["names"])
    lines = _read_lines(value["lines"])
    rules_raw = value["rules"]
    if not isinstance(rules_raw, list) or not rules_raw:
        raise MapError(f"field 'regions.rules' must be a non-empty list, got {rules_raw!r}")
    rules = [_read_rule(i, rule, names, lines) for i, rule in enumerate(rules_raw)]
    if rules[-1].conditions:
        raise MapError(
            "field 'regions.rules': the last rule must be a default (no 'when'), "
            f"got {rules_raw[-1]!r}"
        )
    unreachable = [n for n in names if n not in {r.region for r in rules}]
    if unreachable:
        raise MapError(f"field 'regions.names': region(s) {unreachable} have no rule")
    return RegionSpec(tuple(names), lines, tuple(rules))


def _read_names(names: Any) -> list[str]:
    """``regions.names``: distinct strings, at most :data:`MAX_REGIONS`."""
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise MapError(f"field 'regions.names' must be a non-empty list of strings, got {names!r}")
    if len(set(names)) != len(names):
        raise MapError(f"field 'regions.names' has duplicates: {names!r}")
    if len(names) > MAX_REGIONS:  # before the rules are checked over the map
        raise MapError(
            f"field 'regions.names': {len(names)} regions, more than {MAX_REGIONS} (the learner "
            "keeps an expert and an option critic per region)"
        )
    return names


def _read_lines(lines_raw: Any) -> dict[str, tuple[str, float]]:
    """``regions.lines``: name -> ``("x" | "y", intercept)``."""
    if not isinstance(lines_raw, dict):
        raise MapError("field 'regions.lines' must be a mapping name -> {x: .} or {y: .}")
    lines: dict[str, tuple[str, float]] = {}
    for lname, spec in lines_raw.items():
        if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in ("x", "y"):
            raise MapError(
                f"field 'regions.lines.{lname}' must be {{x: value}} or {{y: value}}, got {spec!r}"
            )
        axis, intercept = next(iter(spec.items()))
        lines[str(lname)] = (axis, read_number(intercept, f"regions.lines.{lname}.{axis}"))
    return lines


def _read_rule(
    i: int, rule: Any, names: list[str], lines: dict[str, tuple[str, float]]
) -> RegionRule:
    """``regions.rules[i]``: ``{region, when}``, its conditions on the named lines."""
    where = f"regions.rules[{i}]"
    if not isinstance(rule, dict) or "region" not in rule:
        raise MapError(f"field {where!r} must be a mapping with 'region', got {rule!r}")
    extra = set(rule) - {"region", "when"}
    if extra:
        raise MapError(f"field {where!r} has unknown key(s) {sorted(extra)}")
    if rule["region"] not in names:
        raise MapError(
            f"field '{where}.region': unknown region {rule['region']!r} (names: {names})"
        )
    when = rule.get("when", [])
    if not isinstance(when, list):
        raise MapError(f"field '{where}.when' must be a list of conditions, got {when!r}")
    conds = []
    for j, text in enumerate(when):
        m = _COND.match(text) if isinstance(text, str) else None
        if m is None:
            raise MapError(
                f"field '{where}.when[{j}]': cannot read condition {text!r} "
                "(expected e.g. 'x > l3' or 'y < l1')"
            )
        axis, op, lname = m.groups()
        if lname not in lines:
            raise MapError(f"field '{where}.when[{j}]': unknown line {lname!r} in {text!r}")
        line_axis, intercept = lines[lname]
        if line_axis != axis:
            raise MapError(
                f"field '{where}.when[{j}]': {text!r} compares {axis} with line {lname!r}, "
                f"which is a {line_axis}-line"
            )
        conds.append(Condition(0 if axis == "x" else 1, op == ">", intercept, text))
    return RegionRule(rule["region"], tuple(conds))


def check_regions(
    regions: RegionSpec,
    bounds: tuple[float, float, float, float],
    free: Polygon,
    source: str,
) -> None:
    """Every region line crosses the map (``bounds``: xmin, xmax, ymin, ymax), and every rule
    owns some of the free area ``free``."""
    xmin, xmax, ymin, ymax = bounds
    for name, (axis, value) in regions.lines.items():
        lo, hi = (xmin, xmax) if axis == "x" else (ymin, ymax)
        if not lo < value < hi:
            raise MapError(
                f"{source}: field 'regions.lines.{name}': {axis} = {value} lies outside the map "
                f"({axis} from {lo} to {hi})"
            )
    taken = None
    for i, rule in enumerate(regions.rules):
        lo_hi = rule.bounds(bounds)
        cell = box(lo_hi[0][0], lo_hi[1][0], lo_hi[0][1], lo_hi[1][1])
        if any(lo >= hi for lo, hi in lo_hi) or free.intersection(cell).area <= 1e-9:
            raise MapError(
                f"{source}: field 'regions.rules[{i}]' (region {rule.region!r}, when "
                f"{[c.text for c in rule.conditions]}) can never fire: it matches no free point"
            )
        fires = cell if taken is None else cell.difference(taken)
        if free.intersection(fires).area <= 1e-9:
            raise MapError(
                f"{source}: field 'regions.rules[{i}]' (region {rule.region!r}, when "
                f"{[c.text for c in rule.conditions]}) can never fire: earlier rules match "
                "every free point it matches"
            )
        taken = cell if taken is None else taken.union(cell)
