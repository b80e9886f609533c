"""Where this package's node programs are, so that commands which start a node themselves (the simulator of
``subsumption run --runtime ros``, slam, amcl, move_base, explore of the experiments) find it in a checkout and
in a catkin install space alike.

In a checkout the nodes sit in ``nodes/`` beside the Python packages. In an install space the Python packages
are in ``lib/python3/dist-packages`` and the nodes in ``lib/subsumption``, found as ``rosrun`` finds them:
through the package on ROS_PACKAGE_PATH (``roslib.packages.find_node``, which asks catkin's libexec folders).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import roslib.packages
import rospkg

PACKAGE = "subsumption"
SOURCE_NODES = Path(__file__).resolve().parents[2] / "nodes"  # the checkout's nodes/ (absent when installed)


class NodeNotFound(FileNotFoundError):
    """A node program of this package is neither beside the code nor in the package ROS finds."""


def node_path(name: str) -> Path:
    """The program of node `name` (``simulator``, ``slam``, ...): the one beside the code when the code runs from
    a checkout (so a checkout never starts an installed copy's node), else the package's, as ``rosrun`` finds
    it with this process's ROS_PACKAGE_PATH and CMAKE_PREFIX_PATH (what the workspace's setup.bash sets)."""
    beside = SOURCE_NODES / name
    if beside.is_file():
        return beside
    package_path = os.environ.get("ROS_PACKAGE_PATH", "")
    rospack = rospkg.RosPack()
    try:
        found = roslib.packages.find_node(PACKAGE, name, rospack=rospack)
    except rospkg.ResourceNotFound:
        found = []
        where = f"package {PACKAGE} is not on ROS_PACKAGE_PATH ({package_path or 'unset'})"
    else:
        where = f"package {PACKAGE} at {rospack.get_path(PACKAGE)} has none"
    if not found:
        raise NodeNotFound(f"no node program '{name}': not in {SOURCE_NODES} and {where}; source the catkin "
                           "workspace's setup.bash (or this checkout's)")
    return Path(found[0])


def node_command(name: str, *args: str) -> list[str]:
    """The command line that starts node `name` with `args` under this interpreter (the one with this package's
    dependencies; an installed node names the same one in its first line)."""
    return [sys.executable, str(node_path(name)), *args]
