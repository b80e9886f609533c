"""Level 0, avoid contact: the TurtleBot stays where it is and backs away from whatever comes towards it.

scan (depth camera) -> blindspot -> scan -> depthmap -> map -> feelforce -> force -> runaway -> heading -> backaway
odom ------------------^                                                                   bumper ---^   -> cmd_vel

The wander robot's feelforce and runaway do the same job here, fed by the depth camera's scan instead of the
sonar ring; what differs on the TurtleBot is written here. Its depth camera looks ahead only (about 58
degrees) and sees nothing nearer than about 0.45 m, so ``depthmap`` reads "too near" as very near (as the
wander robot's sonar module does) and the bumper tells about a thing touching the front. And since the robot
cannot see behind it, ``backaway`` reverses away from what comes at it, keeping it in view, instead of turning
its back on it as the wander robot's turn and forward would.

``blindspot`` is the camera's short-term memory for its blind range. The simulated Kinect, like the real one,
gives no reading at all (NaN) for a thing nearer than 0.45 m: "too near" and "nothing there" look the same, so a
person who walks up to the robot, or a robot it turns back towards, vanishes from the scan, and every level
above drove into things it had seen a moment before. blindspot remembers what the scan saw near it (navigation's
ObstacleMemory, moved by odometry) and, while the scan cannot see that place again, reports it on its own scan
as a thing at the robot's rim: where it may stand now. It is the patrol robot's version of the TurtleBot's
bumper2pointcloud (which puts bumper contacts into move_base's costmap), acting before contact.

The camera cannot see behind the robot either, and every level backs up: backaway away from what comes at it,
bumpturn after a hit. What blindspot remembers of the places now behind the robot (walls it saw before it
turned, bumper contacts) is the only thing it knows there, so blindspot also says how much room that leaves
behind (``behind``), and both modules reverse no faster than lets them stop short of it. Why: on a loaded ROS
graph level 0 does drive under level 1. At the start of the level-1 scene the robot turns to face the
ping-pong room's corner, 0.9 m away, and backaway asks to reverse at 0.5 m/s for seconds on end; each time
forward's commands come more than the suppressor's 0.5 s late (0.64 s measured; 3.4 s with a busy core),
those reversing commands reach the base, and backaway knew nothing of what was behind.
"""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Float64, UInt8

from navigation.obstacle_memory import ObstacleMemory
from navigation.scan_geometry import Beams, MountListener, beams_of
from navigation.scan_sync import OdometryHistory
from subsumption.planar import from_pose_msg
from subsumption import Input, Module, Output, Param

BUMPER_LEFT, BUMPER_CENTRE, BUMPER_RIGHT = 1, 2, 4  # std_msgs/UInt8 bits, as the Kobuki base reports them


class Blindspot(Module):
    """The depth scan with what it saw near the robot a moment ago and cannot see now (see the module docstring).

    Every hit within `near` of the camera is remembered in the odometry frame (navigation's ObstacleMemory). A
    remembered point goes when a beam of the current scan hits something at or beyond it (the place is seen, free or
    still taken: the scan says; a thing inside the blind range would have hidden that hit), when it is `reach` from the
    robot, or `keep` seconds after it was last seen. A beam with no return does not clear it: the camera gives none for
    a thing nearer than its minimum range either. Each scan, a remembered point within the camera's view, no farther
    than `range_min` + `approach` (a thing last seen there may have come on into the blind range), on a beam that now
    has no return, is put on that beam at the robot's rim plus `gap`: nothing tells where it is between there and the
    rim. But a depth camera's minimum is a depth along its optical axis (`depth_camera`): a beam at angle a is blind to
    range_min / cos(a), 0.51 m at the Kinect's 29 degrees. A point farther than range_min and yet hidden by that, at the
    view's edge, is put where it was remembered: the robot's turning took it there, and a thing standing there is hidden
    there. Put at the rim, a door jamb beside a robot in a doorway, at the view's edge beyond 0.45 m from the camera,
    blocked every trajectory of move_base, which gave its goal up as stuck (the office, level 3, seeds 1 and 3). Such a
    point counts as seen again (what the camera shows is what a thing standing there would show), so a thing that stays
    in the blind range is not forgotten while the robot stays near it. The scan's ``range_min`` is lowered to `floor` so
    the rim readings count as hits. A bumper contact is remembered the same way, as points on the rim on the side
    pressed (behind, when the robot was reversing): a thing that came up out of the camera's view and stopped in its
    blind range is known only by touch, and without this the robot turned and drove into it again and again. Without
    odometry (or a mounting from tf) the scan passes unchanged."""

    scan = Input(LaserScan, "the depth camera's scan (REP 117)")
    odom = Input(Odometry, "the base's odometry: moves what is remembered as the robot moves")
    bumper = Input(UInt8, "bumper bits: a contact is remembered too, at the rim on the side pressed")
    filled = Output(LaserScan, "the same scan, its blind range filled from memory: remembered things as hits at the rim")
    behind = Output(Float64, "m of room behind the rear rim, along the robot's width, by what is remembered there "
                             "(at most `reach`: nothing known nearer); sent with every filled scan")
    near = Param(1.0, "m from the camera: hits nearer than this are remembered (the walls beside the robot too: "
                      "what it turns its back on is what it may back into)", min=0.0)
    approach = Param(0.2, "m beyond the minimum range: a remembered thing this near may have come into the "
                          "blind range when its beam lost it", min=0.0)
    keep = Param(60.0, "s a remembered point is kept at most (a thing standing in the blind range stays unseen)",
                 min=0.0)
    reach = Param(1.2, "m from the robot: remembered points farther than this are forgotten", min=0.0)
    radius = Param(0.18, "m: the robot's radius (a TurtleBot's)", min=0.0)
    gap = Param(0.05, "m beyond the rim where a thing in the blind range is put", min=0.0)
    floor = Param(0.1, "m: the output scan's range_min (below the rim readings it adds)", min=0.0)
    depth_camera = Param(True, "the scan is made from a depth image (depthimage_to_laserscan): its range_min is a "
                               "depth, so a beam at angle a is blind to range_min / cos(a) (0.51 m at the "
                               "Kinect's 29 degrees); false: a laser's, range_min on every beam")

    def setup(self) -> None:
        self.memory = ObstacleMemory(self.keep, self.reach)
        self.mounts = MountListener(self.node)
        self._odom: Odometry | None = None
        self._history = OdometryHistory()  # the last seconds of odometry, to find the pose at a scan's stamp
        self._last_bits = 0

    def on_odom(self, msg: Odometry) -> None:
        self._odom = msg
        self._history.add(msg.header.stamp.to_sec(), from_pose_msg(msg.pose.pose))

    def pose_at(self, stamp: float) -> np.ndarray:
        """The odometry pose at `stamp`, interpolated (the latest when the stamp is zero or newer; the oldest
        kept when older). On a loaded ROS graph the latest odometry is newer than the scan, and the robot turns
        meanwhile: remembered points taken with it fell onto the wrong beams (a door jamb onto the beams looking
        down the corridor, which have no return) and came back as things at the rim."""
        history = self._history
        if stamp <= 0 or stamp >= history.latest:
            return history.poses[-1]
        pose = history.at(stamp)
        return history.poses[0] if pose is None else pose

    def on_bumper(self, msg: UInt8) -> None:
        bits = msg.data  # the base repeats a contact at every physics step: once is enough
        if self._odom is None or not bits & (BUMPER_LEFT | BUMPER_CENTRE | BUMPER_RIGHT) or bits == self._last_bits:
            self._last_bits = bits
            return
        self._last_bits = bits
        bearings = [b for bit, side in ((BUMPER_LEFT, BUMP_SIDES[0]), (BUMPER_CENTRE, BUMP_SIDES[1]),
                                        (BUMPER_RIGHT, BUMP_SIDES[2])) if msg.data & bit for b in side]
        if self._odom.twist.twist.linear.x < 0:  # backing up: the contact is behind
            bearings = [math.pi - b for b in bearings]
        angles = np.array(bearings)
        points = (self.radius + self.gap) * np.column_stack((np.cos(angles), np.sin(angles)))
        self.memory.update(self.now(), from_pose_msg(self._odom.pose.pose), EMPTY_BEAMS, 0.0, points)

    def blind_range(self, range_min: float, bearing: np.ndarray) -> np.ndarray:
        """How far along each beam (`bearing`, rad in the scan's frame) the camera sees nothing: a depth camera's
        minimum is a depth along its optical axis, so a beam at angle a is blind to range_min / cos(a)
        (depthimage_to_laserscan's ranges are depths times 1 / cos(a)); a laser's is range_min on every beam."""
        if not self.depth_camera:
            return np.full(len(bearing), range_min)
        return range_min / np.maximum(np.cos(bearing), 0.1)

    def on_scan(self, scan: LaserScan) -> None:
        out = LaserScan(header=scan.header, angle_min=scan.angle_min, angle_max=scan.angle_max,
                        angle_increment=scan.angle_increment, time_increment=scan.time_increment,
                        scan_time=scan.scan_time, range_min=scan.range_min, range_max=scan.range_max,
                        ranges=list(scan.ranges), intensities=list(scan.intensities))
        mount = None
        if self._odom is not None:
            base = self._odom.child_frame_id or scan.header.frame_id
            mount = self.mounts.mount(base.lstrip("/"), scan.header.frame_id.lstrip("/") or base.lstrip("/"))
        if mount is not None and len(scan.ranges):
            self._remember(scan, out, mount)
        self.filled.publish(out)

    def _remember(self, scan: LaserScan, out: LaserScan, mount: tuple[np.ndarray, bool]) -> None:
        beams = beams_of(scan, mount)
        origin = beams.origin
        distance = np.hypot(*(beams.hits() - origin).T) if beams.hit.any() else np.zeros(0)
        near_hits = beams.hits()[distance <= self.near] if len(distance) else np.zeros((0, 2))
        # a beam with no return sees nowhere (too near, or too far: the Kinect says neither)
        seen = Beams(origin, beams.angles, np.where(beams.hit, beams.ranges, 0.0), beams.hit)
        self.memory.keep, self.memory.reach = self.keep, self.reach
        # a hit beyond a remembered place clears it even inside the blind range (a thing there would hide it)
        kept = self.memory.update(self.now(), self.pose_at(scan.header.stamp.to_sec()), seen, 0.0, near_hits)
        self.behind.publish(Float64(min(room_behind(kept, self.radius), self.reach)))  # finite: ROS drops inf
        if not len(kept):
            return
        rel = kept - origin
        dist = np.hypot(rel[:, 0], rel[:, 1])
        pose, flipped = mount
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - pose[2]  # in the scan's frame
        bearing = -bearing if flipped else bearing
        bearing = np.remainder(bearing + math.pi, math.tau) - math.pi
        index = np.round((bearing - scan.angle_min) / scan.angle_increment).astype(int)
        ranges = np.asarray(out.ranges, dtype=float)
        # beyond range_min and yet hidden: at a beam's angle a depth camera is blind to range_min / cos(angle)
        edge = (dist >= scan.range_min) & (dist < self.blind_range(scan.range_min, bearing))
        inside = (index >= 0) & (index < len(ranges)) & (dist <= scan.range_min + self.approach)
        if not inside.any():
            return
        # still unseen where a thing in the blind range would be unseen: as good as seen again (ObstacleMemory
        # keeps the points it returns first, in order)
        self.memory.seen[:len(kept)][inside] = self.now()
        for i, b, d, hidden in zip(index[inside], bearing[inside], dist[inside], edge[inside]):
            if hidden:  # farther than range_min, hidden by depth at the view's edge: standing, it is where it was
                place = float(d)
            else:  # it may have come on, up to the rim
                direction = pose[2] + (-b if flipped else b)  # back in the base frame
                place = ray_to_circle(origin, direction, self.radius) + self.gap
            if not scan.range_min <= ranges[i] <= scan.range_max:  # no return on this beam: it may be there
                ranges[i] = min(place, ranges[i]) if np.isfinite(ranges[i]) and ranges[i] > 0 else place
        out.ranges = [float(r) for r in ranges]
        out.range_min = min(float(self.floor), float(scan.range_min))


BUMP_SIDES = (np.radians([40.0, 60.0, 80.0]), np.radians([-20.0, 0.0, 20.0]), np.radians([-40.0, -60.0, -80.0]))
EMPTY_BEAMS = Beams(np.zeros(2), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool))  # sees nothing, clears nothing


def room_behind(points: np.ndarray, radius: float, side: float = 0.05) -> float:
    """Free distance (m) from the rear rim of a robot of `radius` straight back to the nearest of `points` (base
    frame) in the strip it sweeps reversing (its width plus `side` each way); inf when none is there."""
    if not len(points):
        return math.inf
    x, y = points[:, 0], points[:, 1]
    strip = (x < 0) & (np.abs(y) <= radius + side)
    if not strip.any():
        return math.inf
    rim = np.sqrt(np.maximum(radius * radius - y[strip] ** 2, 0.0))  # the rear rim's x at each point's side
    return float(max(0.0, np.min(-x[strip] - rim)))


def reverse_speed(speed: float, behind: float, margin: float, horizon: float) -> float:
    """The reversing speed (m/s, >= 0) allowed with `behind` m of known room: none within `margin`, and slow
    enough that `horizon` s of late commands still stop short of it. `speed` with nothing known behind."""
    return max(0.0, min(speed, (behind - margin) / horizon))


def ray_to_circle(origin: np.ndarray, direction: float, radius: float) -> float:
    """How far from `origin` (inside the circle of `radius` round the base's centre) a ray along `direction`
    (rad, base frame) leaves that circle: the robot's rim, seen from its camera."""
    dx, dy = math.cos(direction), math.sin(direction)
    along = float(origin[0] * dx + origin[1] * dy)
    inside = along * along - float(origin @ origin) + radius * radius
    return -along + math.sqrt(max(inside, 0.0))


class Depthmap(Module):
    """Turns the depth camera's scan into a coarse robot-centred obstacle map: a LaserScan of `sectors` beams,
    each the nearest reading within its sector of the camera's view. REP 117 readings nearer than the minimum
    (-inf) count as the minimum, so an object inside the camera's blind distance reads "very close"; +inf
    (nothing within range) and NaN add nothing. feelforce and collide read this map as they read the
    wander robot's sonar map."""

    scan = Input(LaserScan, "the depth camera's scan (or any forward-looking scan)")
    map = Output(LaserScan, "one range per sector, sector i centred at angle_min + i * angle_increment")
    sectors = Param(3, "number of sectors the view is cut into", min=1)

    def on_scan(self, scan: LaserScan) -> None:
        ranges = np.asarray(scan.ranges, dtype=float)
        if ranges.size == 0:
            return
        near = np.isneginf(ranges) | (np.isfinite(ranges) & (ranges < scan.range_min))
        ranges = np.where(near, scan.range_min, ranges)
        ranges = np.where(np.isnan(ranges) | (ranges > scan.range_max), np.inf, ranges)
        parts = np.array_split(ranges, min(self.sectors, ranges.size))
        width = scan.angle_increment * ranges.size / len(parts)
        out = LaserScan()
        out.header = scan.header
        out.angle_min = scan.angle_min - scan.angle_increment / 2 + width / 2
        out.angle_increment = width
        out.angle_max = out.angle_min + width * (len(parts) - 1)
        out.range_min, out.range_max = scan.range_min, scan.range_max
        out.ranges = [float(part.min()) for part in parts]
        self.map.publish(out)


class Backaway(Module):
    """The TurtleBot's level-0 motor module: stands still until told to flee, then reverses away, keeping the
    thing that comes at it in front of the camera. A heading behind the robot (runaway's "away from it")
    backs it up, steering so that its back points that way; a heading ahead drives it forward (something
    touched it from behind). A bumper hit backs it straight up for `bump_hold` seconds, whatever the scan says:
    the camera cannot see a thing that close. It reverses blind, so never faster than blindspot's `behind` (the
    room it remembers behind) allows: it stops `rear_margin` short of a wall it saw before it turned, or of a
    contact behind, with `rear_time` s of late commands to spare."""

    heading = Input(Float64, "runaway: the way away from the obstacles, rad relative to the robot")
    bumper = Input(UInt8, "bumper bits: 1 left, 2 centre, 4 right; 0 released")
    behind = Input(Float64, "blindspot: m of room behind the rear rim as remembered (none yet: nothing known)")
    cmd_vel = Output(Twist, "velocity command to the base")
    speed = Param(0.5, "m/s backing away (faster than a person walking slowly at the robot)")
    max_rate = Param(1.0, "rad/s")
    gain = Param(2.0, "rad/s per rad of heading error")
    period = Param(0.1, "s between commands")
    hold = Param(0.5, "s a heading stays valid")
    bump_hold = Param(1.0, "s the robot keeps backing up after a bumper hit")
    rear_margin = Param(0.1, "m short of a thing remembered behind where reversing stops", min=0.0)
    rear_time = Param(0.5, "s: reversing no faster than covers the room behind, less the margin, in this time",
                      min=0.01)

    def setup(self) -> None:
        self._heading_at = -math.inf
        self._bumped_at = -math.inf
        self.every(self.period, self.drive)

    def on_heading(self, msg: Float64) -> None:
        self._heading_at = self.now()

    def on_bumper(self, msg: UInt8) -> None:
        if msg.data & (BUMPER_LEFT | BUMPER_CENTRE | BUMPER_RIGHT):
            self._bumped_at = self.now()

    def drive(self) -> None:
        now = self.now()
        command = Twist()
        if now - self._bumped_at <= self.bump_hold:
            command.linear.x = -self.speed
        elif self.registers.heading is not None and now - self._heading_at <= self.hold:
            heading = math.remainder(self.registers.heading.data, math.tau)
            backwards = abs(heading) > math.pi / 2
            error = math.remainder(heading - math.pi, math.tau) if backwards else heading
            command.angular.z = max(-self.max_rate, min(self.max_rate, self.gain * error))
            command.linear.x = (-1.0 if backwards else 1.0) * self.speed * math.cos(error) ** 2
        if command.linear.x < 0:
            command.linear.x = -min(-command.linear.x, self.reverse_limit())
        self.cmd_vel.publish(command)

    def reverse_limit(self) -> float:
        behind = self.registers.behind
        return reverse_speed(self.speed, math.inf if behind is None else behind.data, self.rear_margin, self.rear_time)
