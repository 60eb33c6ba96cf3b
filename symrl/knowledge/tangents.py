"""Tangent geometry of the planner: tangents from a point to a circle and between two equal circles.

A disc robot keeping a clearance ``r`` from polygonal walls moves like a point among circles of
radius ``r`` around the wall vertices; its shortest paths are made of these tangents and arcs of
the circles (:mod:`symrl.knowledge.planner`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["tangent_angles", "bitangent_angles", "on_circle"]


def tangent_angles(p: np.ndarray, c: np.ndarray, r: float) -> list[float]:
    """Angles (around c) of the tangent points from point p to the circle (c, r)."""
    d = float(np.hypot(*(p - c)))
    if d < r - 1e-12:
        return []
    base = math.atan2(p[1] - c[1], p[0] - c[0])
    off = math.acos(min(1.0, r / d))
    return [base + off, base - off] if off > 1e-12 else [base]


def bitangent_angles(c1: np.ndarray, c2: np.ndarray, r: float) -> list[tuple[float, float]]:
    """Pairs of angles (on circle 1, on circle 2) of the tangent segments of two equal circles."""
    v = c2 - c1
    d = float(np.hypot(*v))
    if d < 1e-12:
        return []
    base = math.atan2(v[1], v[0])
    pairs = [(base + math.pi / 2, base + math.pi / 2), (base - math.pi / 2, base - math.pi / 2)]
    if d > 2 * r:  # inner (crossing) tangents through the midpoint
        off = math.acos(2 * r / d)
        pairs += [(base + off, base + off + math.pi), (base - off, base - off + math.pi)]
    return pairs


def on_circle(c: np.ndarray, r: float, a: float) -> np.ndarray:
    return c + r * np.array([math.cos(a), math.sin(a)])
