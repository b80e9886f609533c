"""subsim: a small 2D robot simulator in the spirit of stdr, for subsumption experiments.

Layers, each usable alone: :mod:`subsim.mapio` (map_server maps), :mod:`subsim.world` (world files),
:mod:`subsim.sim` (the pure simulation, numpy in and out), :mod:`subsim.messages` (state as ROS messages),
:mod:`subsim.bridge` (topics through a NodeHandle), :mod:`subsim.local` (attach to a LocalRuntime),
:mod:`subsim.ros_node` (the ROS node), :mod:`subsim.plot` (trajectory pictures).
"""
from pathlib import Path

from .mapio import GridMap, MapError, load_map
from .sim import Reading, Simulation
from .world import World, WorldError, load_world

MAPS = Path(__file__).resolve().parent / "maps"


def world_path(name: str) -> Path:
    """Path of a shipped world: "room", "corridors", "sparse", "pingpong" or "office" (and generated ones)."""
    return MAPS / f"{name}_world.yaml"


__all__ = ["GridMap", "MapError", "load_map", "Reading", "Simulation", "World", "WorldError", "load_world",
           "MAPS", "world_path"]
