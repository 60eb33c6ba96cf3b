"""ROS occupancy maps as worlds: read a ``map_server`` map (YAML + image), trace its walls.

A ``map_server`` / ``map_saver`` map is an image (PGM, PNG, ...) and a YAML with ``image``,
``resolution`` (m per cell), ``origin`` (x, y, yaw of the lower-left pixel), ``negate``,
``occupied_thresh``, ``free_thresh`` and ``mode`` (``trinary``, ``scale`` or ``raw``). Every
field is honoured as ``map_server`` reads it (see :func:`free_cells`). Unknown cells, and the
intermediate cells of ``scale`` and ``raw``, count as walls: the robot drives only where the map
says free.

The free space a world is made of is the connected free area holding the start. It is traced
with shapely (the union of each image row's free runs, then simplified within one cell), so
its outer ring becomes the map's ``boundary`` and its holes its ``obstacles``. Pillow reads the
image. Nothing here knows of :mod:`symrl.world.worldmap`, which calls :func:`trace_world` and
turns an :class:`OccupancyError` into its one-line ``MapError``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import yaml
from PIL import Image, UnidentifiedImageError
from shapely import affinity
from shapely.geometry import Point, Polygon

__all__ = [
    "OccupancyError",
    "OccupancyMap",
    "read_occupancy",
    "free_cells",
    "trace_world",
    "MODES",
]

MODES = ("trinary", "scale", "raw")
"""The ``mode`` values of ``map_server``."""
_KEYS = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
_ERODE = 1e-3
"""Cells (a fraction of one) the traced free area is shrunk by: it parts free cells that touch
only at a corner (no robot passes there), so every ring comes out simple."""


class OccupancyError(ValueError):
    """A map_server map is malformed; the message names the file, the field and the value."""


@dataclass(frozen=True)
class OccupancyMap:
    """A read map_server map: which cells are free, and where they lie in the world."""

    free: np.ndarray
    """(rows, cols) bool, in image order: row 0 is the top of the image (the largest y)."""
    resolution: float
    """Metres per cell."""
    origin: tuple[float, float, float]
    """x, y (m) and yaw (rad) of the lower-left corner of the lower-left cell."""
    image: Path

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(left, right, bottom, top) in metres for ``imshow`` (yaw 0)."""
        rows, cols = self.free.shape
        ox, oy, _ = self.origin
        return ox, ox + cols * self.resolution, oy, oy + rows * self.resolution

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        """(row, col) of the cell holding the point, None outside the image."""
        ox, oy, yaw = self.origin
        dx, dy = x - ox, y - oy
        c, s = math.cos(yaw), math.sin(yaw)
        u, v = (c * dx + s * dy) / self.resolution, (-s * dx + c * dy) / self.resolution
        rows, cols = self.free.shape
        col, up = math.floor(u), math.floor(v)
        if not (0 <= col < cols and 0 <= up < rows):
            return None
        return rows - 1 - up, col


def _number(doc: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    value = doc.get(key, default)
    if value is None:
        raise OccupancyError(f"{where}: missing field {key!r}")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise OccupancyError(f"{where}: field {key!r} must be a finite number, got {value!r}")
    return float(value)


def read_occupancy(path: str | Path) -> OccupancyMap:
    """Read a map_server YAML and its image (``image`` relative to the YAML's folder)."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise OccupancyError(f"occupancy map {where!r} does not exist")
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        reason = " ".join(str(err).split())
        raise OccupancyError(f"occupancy map {where!r} is not a readable YAML: {reason}") from None
    if not isinstance(doc, dict):
        raise OccupancyError(f"{where}: a map_server YAML must be a mapping, got {doc!r}")
    unknown = set(doc) - _KEYS
    if unknown:
        raise OccupancyError(
            f"{where}: unknown field(s) {sorted(unknown)}; allowed: {sorted(_KEYS)}"
        )
    image = doc.get("image")
    if not isinstance(image, str) or not image:
        raise OccupancyError(f"{where}: field 'image' must be a file name, got {image!r}")
    resolution = _number(doc, "resolution", where)
    if resolution <= 0:
        raise OccupancyError(f"{where}: field 'resolution' must be positive, got {resolution!r}")
    origin = doc.get("origin")
    if (
        not isinstance(origin, list)
        or len(origin) not in (2, 3)
        or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in origin
        )
    ):
        raise OccupancyError(f"{where}: field 'origin' must be [x, y, yaw], got {origin!r}")
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise OccupancyError(f"{where}: field 'negate' must be 0 or 1, got {negate!r}")
    occupied = _number(doc, "occupied_thresh", where, 0.65)
    free = _number(doc, "free_thresh", where, 0.196)
    if not 0.0 <= free <= occupied <= 1.0:
        raise OccupancyError(
            f"{where}: need 0 <= free_thresh <= occupied_thresh <= 1, got free_thresh {free!r} "
            f"and occupied_thresh {occupied!r}"
        )
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise OccupancyError(f"{where}: field 'mode' must be one of {list(MODES)}, got {mode!r}")
    image_path = Path(image) if Path(image).is_absolute() else path.parent / image
    if not image_path.is_file():
        raise OccupancyError(f"{where}: field 'image': {str(image_path)!r} does not exist")
    try:
        with Image.open(image_path) as img:
            pixels, alpha = _pixels(img)
    except (UnidentifiedImageError, OSError, ValueError) as err:
        reason = " ".join(str(err).split())
        raise OccupancyError(
            f"{where}: field 'image': cannot read {str(image_path)!r}: {reason}"
        ) from None
    cells = free_cells(pixels, mode, bool(negate), occupied, free, alpha)
    o = [float(v) for v in origin] + [0.0] * (3 - len(origin))
    return OccupancyMap(cells, resolution, (o[0], o[1], o[2]), image_path)


def _pixels(img: Image.Image) -> tuple[np.ndarray, np.ndarray | None]:
    """The image's per-pixel colour average (0-255, the mean of its colour channels) and its
    alpha (0-1) if it has one, as map_server takes them (16-bit grey scaled to 8 bits)."""
    img.load()
    if img.mode.startswith("I"):
        return np.asarray(img, dtype=np.float64) * (255.0 / 65535.0), None
    if img.mode in ("RGBA", "LA", "PA") or "transparency" in img.info:
        rgba = np.asarray(img.convert("RGBA"), dtype=np.float64)
        return rgba[..., :3].mean(axis=2), rgba[..., 3] / 255.0
    if img.mode in ("L", "1"):
        return np.asarray(img.convert("L"), dtype=np.float64), None
    return np.asarray(img.convert("RGB"), dtype=np.float64).mean(axis=2), None


def free_cells(
    colour: np.ndarray,
    mode: str,
    negate: bool,
    occupied_thresh: float,
    free_thresh: float,
    alpha: np.ndarray | None = None,
) -> np.ndarray:
    """Which cells are free, as map_server reads a pixel of colour average ``colour`` (0-255):

    ``negate`` turns the colour to ``255 - colour``. In ``trinary`` and ``scale`` the occupancy
    is ``p = (255 - colour) / 255``: free when ``p < free_thresh`` (occupied above
    ``occupied_thresh``, unknown or scaled between). ``scale`` also makes a transparent pixel
    (alpha < 1) unknown. In ``raw`` the colour is the occupancy value itself (0-100, beyond:
    unknown): free when ``value / 100 < free_thresh``."""
    c = np.asarray(colour, dtype=np.float64)
    if negate:
        c = 255.0 - c
    if mode == "raw":
        value = np.rint(c)
        return (value <= 100.0) & (value / 100.0 < free_thresh)
    free = (255.0 - c) / 255.0 < free_thresh
    if mode == "scale" and alpha is not None:
        free &= alpha >= 1.0
    return np.asarray(free)


def _free_area(free: np.ndarray) -> shapely.Geometry:
    """The free cells as one geometry in cell units (x = column, y = rows from the bottom)."""
    rows = free.shape[0]
    padded = np.zeros((rows, free.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = free
    step = np.diff(padded, axis=1)
    r0, c0 = np.nonzero(step == 1)
    r1, c1 = np.nonzero(step == -1)  # same rows, same order: runs [c0, c1)
    if len(r0) == 0:
        return Polygon()
    up = (rows - 1 - r0).astype(np.float64)
    boxes = shapely.box(c0.astype(np.float64), up, c1.astype(np.float64), up + 1.0)
    return shapely.unary_union(boxes)


def trace_world(
    occ: OccupancyMap,
    start: tuple[float, float],
    goal: tuple[float, float],
    where: str,
) -> tuple[np.ndarray, list[np.ndarray]]:
    """The free space connected to ``start``, traced: the boundary ring ``(k, 2)`` and the hole
    rings (the obstacles), in metres, walls simplified within one cell. Raises
    :class:`OccupancyError` when the start or goal lies outside the image, in a wall or in
    unknown space, or when the goal is not connected to the start."""
    for label, (x, y) in (("start", start), ("goal", goal)):
        cell = occ.cell_of(x, y)
        if cell is None:
            raise OccupancyError(
                f"{where}: field {label!r}: ({x}, {y}) lies outside the occupancy map "
                f"{str(occ.image)!r} (extent x {occ.extent[0]:g}..{occ.extent[1]:g}, "
                f"y {occ.extent[2]:g}..{occ.extent[3]:g})"
            )
        if not occ.free[cell]:
            raise OccupancyError(
                f"{where}: field {label!r}: ({x}, {y}) lies in a wall or in unknown space of "
                f"{str(occ.image)!r} (cell row {cell[0]}, column {cell[1]})"
            )
    area = _free_area(occ.free).buffer(-_ERODE, join_style="mitre")
    ox, oy, yaw = occ.origin
    res = occ.resolution

    def to_cells(x: float, y: float) -> Point:
        c, s = math.cos(yaw), math.sin(yaw)
        return Point((c * (x - ox) + s * (y - oy)) / res, (-s * (x - ox) + c * (y - oy)) / res)

    pieces = list(getattr(area, "geoms", [area]))
    here = to_cells(*start)
    part = min(pieces, key=here.distance)
    goal_cell = occ.cell_of(*goal)
    assert goal_cell is not None  # checked above
    rows = occ.free.shape[0]
    centre = Point(goal_cell[1] + 0.5, rows - 1 - goal_cell[0] + 0.5)
    if not part.covers(centre):
        raise OccupancyError(
            f"{where}: field 'goal': ({goal[0]}, {goal[1]}) is not in the free space connected "
            f"to the start ({start[0]}, {start[1]}) in {str(occ.image)!r}"
        )
    part = part.simplify(1.0, preserve_topology=True)  # within one cell
    part = affinity.affine_transform(part, [res, 0.0, 0.0, res, 0.0, 0.0])
    if yaw:
        part = affinity.rotate(part, yaw, origin=(0.0, 0.0), use_radians=True)
    part = affinity.translate(part, ox, oy)
    part = shapely.set_precision(part, 1e-6)  # micrometres: tidy numbers in the map file
    if not isinstance(part, Polygon) or part.is_empty:
        raise OccupancyError(
            f"{where}: the free space around the start in {str(occ.image)!r} is too small to trace"
        )
    holes = [_ring(h) for h in part.interiors if Polygon(h).area > 0.0]
    return _ring(part.exterior), holes


def _ring(ring: Any) -> np.ndarray:
    """A shapely ring's points without the closing repeat."""
    return np.asarray(ring.coords, dtype=np.float64)[:-1]
