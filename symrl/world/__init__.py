"""The world: map files, geometry (ray casting), the B21 robot model and the Gymnasium env."""

from symrl.world.env import Hailu2001Env
from symrl.world.geometry import Walls
from symrl.world.robot import RobotConfig
from symrl.world.worldmap import MapError, WorldMap, load_map

__all__ = ["Hailu2001Env", "MapError", "RobotConfig", "Walls", "WorldMap", "load_map"]
