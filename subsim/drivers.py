"""How each robot kind's driver names and sends things, so that the simulator can pose as a real robot.

A user with a TurtleBot runs its vendor's driver, which has its own topic names, message types, rates and frames;
the simulator, told ``kind: turtlebot2`` or ``kind: turtlebot3`` in the world file, speaks exactly as that driver
does, so that what runs against the simulator runs against the robot unchanged:

=================  ==========================================  =================================================
kind               takes / sends                                frames, rates
=================  ==========================================  =================================================
``robot``,         ``cmd_vel``; ``odom``, ``scan``, ``sonar``,  odom -> base_link, everything at the sensor rate
``turtlebot``      ``bumper`` (std_msgs/UInt8 bitmask)          (the project's own names, as before)
``turtlebot2``     ``mobile_base/commands/velocity`` (kobuki;   odom -> base_footprint -> base_link (z 0.0102),
                   0.6 s timeout); ``odom`` 50 Hz;              odom and its tf at 50 Hz, as kobuki_node sends them;
                   ``mobile_base/events/{bumper,cliff,          the Kinect's topics and optical frames at 30 Hz
                   wheel_drop}`` (kobuki_msgs, on change:
                   the world's ``cliffs`` under the three cliff
                   sensors, its ``robots[].lifted`` spans)
``turtlebot3``     ``cmd_vel`` (0.5 s timeout); ``odom`` 30 Hz; odom -> base_footprint -> base_link (z 0.010) ->
(Burger)           ``scan`` 5 Hz: the LDS-01, 360 beams from     base_scan (z 0.172); 0.0 where a beam returned
                   0 rad counter-clockwise, 0.12-3.5 m          nothing, as hls_lfcd_lds_driver sends it
=================  ==========================================  =================================================

The command timeouts (kobuki 0.6 s, TurtleBot 3 0.5 s) are the kinds' ``limits.cmd_timeout`` defaults
(subsim.world.KIND_DEFAULTS).

Sources: kobuki_node and turtlebot_bringup (minimal.launch, mobile_base.launch.xml: the nodelet ``mobile_base``
with ``odom`` remapped to ``/odom``; ``cmd_vel_timeout`` 0.6 s; odometry with every 50 Hz sensor packet),
turtlebot_description (base_footprint 0.0102 m below base_link); turtlebot3_bringup / turtlebot3_core firmware
(``cmd_vel``, ``odom`` and tf at 30 Hz, the motors stop 0.5 s after the last command), turtlebot3_description
(Burger: base_scan at (-0.032, 0, 0.172) on base_link; the simulator's laser sits at the centre, so its frame is
published at (0, 0, 0.172)) and hls_lfcd_lds_driver (angle_min 0, angle_max 2 pi, 1 degree, 0.12-3.5 m, 0 for no
return, 300 rpm).
"""
from __future__ import annotations

from dataclasses import dataclass

KOBUKI = "kobuki"
BITMASK = "bitmask"
# the Kobuki's three cliff sensors on base_link, left, centre (front), right: kobuki_description's
# kobuki_gazebo.urdf.xacro (cliff_sensor_{left,front,right}_joint), x ahead, y to the left
KOBUKI_CLIFF_SENSORS = ((0.08734, 0.13601), (0.156, 0.0), (0.085, -0.13601))


@dataclass(frozen=True)
class Driver:
    """The names, rates and conventions a kind's driver uses (topics relative to the robot's namespace)."""

    kind: str
    cmd_vel: str = "cmd_vel"
    odom: str = "odom"
    scan: str = "scan"
    sonar: str = "sonar"
    bumper: str | None = "bumper"  # None: the base has no bumper topic
    bumper_style: str = BITMASK  # "bitmask" (std_msgs/UInt8, every step in contact) or "kobuki" (events)
    cliff: str | None = None  # kobuki_msgs/CliffEvent topic, if the base has cliff sensors
    wheel_drop: str | None = None  # kobuki_msgs/WheelDropEvent topic
    footprint: str | None = None  # the odometry's child frame when it is not base_link (REP 120's base_footprint)
    footprint_height: float = 0.0  # m of base_link above base_footprint
    laser_frame: str = "laser"
    laser_height: float = 0.0
    odom_rate: float | None = None  # Hz of odom and its tf; None: the bridge's sensor rate
    scan_rate: float | None = None  # Hz of the laser; None: the sensor rate
    zero_no_return: bool = False  # a laser beam with no return reads 0.0 (older drivers), not +inf (REP 117)
    # (x, y) m on the base of each cliff sensor, in the order of the cliff events' sensor index (left, centre, right)
    cliff_sensors: tuple[tuple[float, float], ...] = ()

    @property
    def own_names(self) -> bool:
        """True for the project's own kinds, whose topics and timing the bridge keeps as they always were."""
        return self.kind in ("robot", "turtlebot")


DRIVERS = {
    "robot": Driver("robot"),
    "turtlebot": Driver("turtlebot"),
    "turtlebot2": Driver(
        "turtlebot2", cmd_vel="mobile_base/commands/velocity", bumper="mobile_base/events/bumper",
        bumper_style=KOBUKI, cliff="mobile_base/events/cliff", wheel_drop="mobile_base/events/wheel_drop",
        footprint="base_footprint", footprint_height=0.0102, odom_rate=50.0,
        cliff_sensors=KOBUKI_CLIFF_SENSORS),
    "turtlebot3": Driver(
        "turtlebot3", bumper=None, footprint="base_footprint", footprint_height=0.010, laser_frame="base_scan",
        laser_height=0.172, odom_rate=30.0, scan_rate=5.0, zero_no_return=True),
}


def driver(kind: str) -> Driver:
    return DRIVERS[kind]
