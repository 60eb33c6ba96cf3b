"""The world: map files, geometry (ray casting), the B21 robot model and the Gymnasium env."""

from symrl.world.worldmap import MapError, WorldMap, load_map

__all__ = ["MapError", "WorldMap", "load_map"]
