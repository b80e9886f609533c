"""The topics the terminal exposes, each under a ROS parameter so a robot can wire it where it likes.

Every name is relative to the robot's namespace (the terminal node's own namespace) unless it starts with
``/``. Clients see the resolved names (``/camera/rgb/image_raw/compressed``, or ``/robot1/...`` in a
namespace) and may also use the relative ones. Only the four command topics can be published, and only by
the client holding control.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Role:
    """One exposed topic: what it is for, its parameter and default name, its type as clients see it."""

    role: str
    default: str
    type: str
    command: bool = False  # published by the operator (in), else watched (out)
    keep: int = 1          # messages queued per subscriber: 1 = only the newest matters
    doc: str = ""

    @property
    def param(self) -> str:
        """The private parameter that renames the role's topic (``~<role>_topic``)."""
        return f"~{self.role}_topic"


ROLES: tuple[Role, ...] = (
    Role("camera", "camera/rgb/image_raw/compressed", "sensor_msgs/CompressedImage",
         doc="camera frames, JPEG (a raw sensor_msgs/Image topic is accepted and encoded)"),
    Role("box", "track/box", "sensor_msgs/RegionOfInterest", doc="the tracked target's box in the image"),
    Role("map", "/map", "nav_msgs/OccupancyGrid", doc="the map"),
    Role("pose", "amcl_pose", "geometry_msgs/PoseWithCovarianceStamped", doc="the localizer's pose"),
    Role("robot_pose", "terminal/robot_pose", "geometry_msgs/PoseStamped",
         doc="the robot in the map, published by the terminal from tf (map -> base_link) or amcl_pose"),
    Role("goals", "patrol/goals", "geometry_msgs/PoseArray", doc="the patrol's goals"),
    Role("plan", "move_base/plan", "nav_msgs/Path", doc="the planned path"),
    Role("target", "target_pose", "geometry_msgs/PointStamped", doc="the followed target in the map"),
    Role("alarms", "alarm", "diagnostic_msgs/DiagnosticArray", keep=50,
         doc="alarms: a status each; WARN/ERROR raised, OK cleared; values x, y"),
    Role("diagnostics", "/diagnostics", "diagnostic_msgs/DiagnosticArray", keep=50,
         doc="every node's health, including each arbiter's holder"),
    Role("status", "terminal/status", "diagnostic_msgs/DiagnosticStatus",
         doc="the terminal's own state: operator, clients, commands"),
    Role("cmd_vel", "terminal/cmd_vel", "geometry_msgs/Twist", command=True, keep=10,
         doc="motor commands while a key is held; into a suppressor on the motor line"),
    Role("manual_target", "terminal/target", "sensor_msgs/RegionOfInterest", command=True, keep=10,
         doc="the box selected by hand; into a suppressor on the target line"),
    Role("stop", "terminal/stop", "std_msgs/Empty", command=True, keep=10,
         doc="stop, sent repeatedly while stop is on; an inhibitor's upper line on the motor line"),
    Role("release", "terminal/release", "std_msgs/Empty", command=True, keep=10,
         doc="control handed back: the robot's own levels take over again"),
)
ROLE_BY_NAME = {role.role: role for role in ROLES}
ARBITER_STATUS_TYPE = "diagnostic_msgs/DiagnosticStatus"
ARBITER_KEEP = 5


def arbiter_role(arbiter: str) -> Role:
    """The latched ``~status`` of an arbiter node named `arbiter` (subsumption.ros.arbiter_node)."""
    return Role(f"arbiter:{arbiter}", f"{arbiter}/status", ARBITER_STATUS_TYPE, keep=ARBITER_KEEP,
                doc=f"arbiter {arbiter}: which line holds its output")
