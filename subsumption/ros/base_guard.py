"""The motor guard node: the last step of the motor line before a real base (see :mod:`subsumption.safety`).

``rosrun subsumption base_guard _profile:=turtlebot2 cmd_vel:=/the/last/arbiter/output``

It takes the network's motor line on ``cmd_vel`` (remap it to the last arbiter's output) and sends the base, on
the profile's ``base.cmd_vel`` (``~output`` overrides it), every command capped in speed and acceleration; it
stops the base at once, from the event's own callback, when the profile's bumper, cliff or wheel-drop event
topic reports a press, a cliff or a dropped wheel. Parameters: ``~profile`` (a shipped profile's name or a
file; required), ``~max_v``, ``~max_reverse``, ``~max_w``, ``~acc_v``, ``~acc_w`` (override the profile's
limits), ``~clock_timeout`` (wall s, 1.0: on simulated time, ROS time standing still this long is a lost
clock; 0: never), ``~deadman_timeout`` (wall s, 0 = off: when > 0 the base moves only while something arrives on
``deadman``, of any type, at least this often: an operator's enable button or heartbeat), ``~output``.
``~needs`` (ROBOT:LEVEL, e.g. ``wander:2``; none: no wait) holds every command until each topic the profile
says that robot needs at that level has spoken, and refuses the run (one line, exit status 2: a launch that
marks the guard required then ends) when one is still silent ``~sensor_wait`` wall s (20) after the clock started.
``~status`` (diagnostic_msgs/DiagnosticStatus, latched) says what holds the base and how many stops each cause
made, on every change and once a second.

The clock and the dead-man are watched on the wall clock, in a thread of their own: this is where the wall clock
is meant (a graph whose clock has stopped has no ROS time to time anything with, and an operator's hand lives
on the wall clock).
"""
from __future__ import annotations

import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist
from std_msgs.msg import UInt8

from .. import kobuki
from ..profile import ProfileError, load_profile
from ..safety import BUMPER, CLIFF, CLOCK, DEADMAN, SENSORS, WHEEL_DROP, Caps, MotorGuard

WATCH_PERIOD = 0.02  # wall s between looks at the clock and the dead-man
STATUS_PERIOD = 1.0  # wall s between status messages when nothing changes


def _active(kind: str, msg) -> list[tuple[int, bool]]:
    """(sensor index, active) pairs one event message reports: a kobuki event, or a bitmask of every sensor."""
    if isinstance(msg, UInt8):
        return [(i, bool(msg.data & (1 << i))) for i in range(3)]
    if kind == BUMPER:
        return [(msg.bumper, msg.state == kobuki.BumperEvent.PRESSED)]
    if kind == CLIFF:
        return [(msg.sensor, msg.state == kobuki.CliffEvent.CLIFF)]
    return [(msg.wheel, msg.state == kobuki.WheelDropEvent.DROPPED)]


EVENT_TYPES = {"kobuki_msgs/BumperEvent": kobuki.BumperEvent, "kobuki_msgs/CliffEvent": kobuki.CliffEvent,
               "kobuki_msgs/WheelDropEvent": kobuki.WheelDropEvent, "std_msgs/UInt8": UInt8}


class BaseGuardNode:
    """The motor guard on ROS: caps the network's commands to the profile's limits and stops the base on its bumper,
    cliff and wheel-drop events, a lost clock or a silent dead-man."""
    def __init__(self) -> None:
        self.name = rospy.get_name()
        profile_name = rospy.get_param("~profile", "")
        if not profile_name:
            raise ProfileError(self.name, "~profile", "missing: the robot profile (turtlebot2, turtlebot3, generic, "
                                                      "sim or a file)")
        profile = load_profile(profile_name)
        caps = profile.caps
        values = {key: rospy.get_param(f"~{key}", getattr(caps, key)) for key in ("max_v", "max_w", "acc_v", "acc_w")}
        values["max_reverse"] = rospy.get_param("~max_reverse", caps.max_reverse)
        try:
            caps = Caps(**{k: (float(v) if v is not None else None) for k, v in values.items()})
        except (TypeError, ValueError) as error:
            raise ProfileError(self.name, "~max_v/~max_w/~acc_v/~acc_w/~max_reverse", str(error)) from None
        self.guard = MotorGuard(caps)
        self.clock_timeout = float(rospy.get_param("~clock_timeout", 1.0))
        self.deadman_timeout = float(rospy.get_param("~deadman_timeout", 0.0))
        self.sim_time = bool(rospy.get_param("/use_sim_time", False))
        self._lock = threading.Lock()
        output = rospy.get_param("~output", profile.cmd_vel)
        self._out = rospy.Publisher(output, Twist, queue_size=1, tcp_nodelay=True)
        self._status = rospy.Publisher("~status", DiagnosticStatus, queue_size=5, latch=True)
        for kind, event in profile.events.items():
            if event.type not in EVENT_TYPES:
                raise ProfileError(profile.path, f"base.{kind}.type",
                                   f"{event.type} is not one the guard reads ({', '.join(EVENT_TYPES)})")
            rospy.Subscriber(event.topic, EVENT_TYPES[event.type], lambda m, k=kind: self._on_event(k, m),
                             tcp_nodelay=True)
        self._last_deadman = -float("inf")
        if self.deadman_timeout > 0:
            rospy.Subscriber("deadman", rospy.AnyMsg, self._on_deadman)
        # the sensors the network needs (~needs: "wander:2"): commands are held until each has spoken, and the
        # run is refused (exit 2) when one stays silent for ~sensor_wait wall seconds of a running clock
        needs = str(rospy.get_param("~needs", ""))
        self.silent: dict[str, str] = {}
        self.sensor_wait = float(rospy.get_param("~sensor_wait", 20.0))
        self.refused = ""
        if needs:
            robot, _, level = needs.partition(":")
            try:
                wanted = [t for t in profile.needed(robot, int(level or 0)) if t.rate > 0]
            except ValueError:
                raise ProfileError(self.name, "~needs", f"expected ROBOT:LEVEL (wander:2), got {needs!r}") from None
            self.silent = {t.topic: f"{t.type}, needed by the {robot} robot from level {t.needs[robot]}"
                           for t in wanted}
            for topic in list(self.silent):
                rospy.Subscriber(topic, rospy.AnyMsg, lambda _m, t=topic: self._heard(t))
            if self.silent:
                self.guard.held.add(SENSORS)
        rospy.Subscriber("cmd_vel", Twist, self._on_command, queue_size=1, tcp_nodelay=True)
        self._changed = True
        threading.Thread(target=self._watch, name="base-guard-watch", daemon=True).start()
        rospy.loginfo("%s: profile %s, %s -> %s; caps v %.2f (reverse %.2f) m/s, w %.2f rad/s, acc %.2f m/s2, "
                      "%.2f rad/s2; stops on %s", self.name, profile.name, rospy.resolve_name("cmd_vel"), output,
                      caps.max_v, caps.reverse, caps.max_w, caps.acc_v, caps.acc_w,
                      ", ".join(e.topic for e in profile.events.values()) or "no events")

    def _send(self, v: float, w: float) -> None:
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self._out.publish(msg)

    def _on_command(self, msg: Twist) -> None:
        with self._lock:
            v, w = self.guard.command(msg.linear.x, msg.angular.z, rospy.get_time())
        self._send(v, w)

    def _on_event(self, kind: str, msg) -> None:
        stop = False
        with self._lock:
            for sensor, active in _active(kind, msg):
                stop |= self.guard.contact(kind, sensor, active)
            self._changed = True
        if stop:
            self._send(0.0, 0.0)
            rospy.logwarn("%s: %s: stopped the base", self.name, kind.replace("_", " "))

    def _heard(self, topic: str) -> None:
        if topic in self.silent:
            with self._lock:
                self.silent.pop(topic, None)
                if not self.silent:
                    self.guard.held.discard(SENSORS)
                    self._changed = True
            if not self.silent:
                rospy.loginfo("%s: every sensor the network needs has spoken: commands pass", self.name)

    def _on_deadman(self, _msg) -> None:
        self._last_deadman = time.monotonic()  # wall clock: an operator's hand

    def _hold(self, reason: str, on: bool, why: str) -> None:
        with self._lock:
            was = reason in self.guard.held
            stop = self.guard.hold(reason, on)
            self._changed |= was != on
        if stop:
            self._send(0.0, 0.0)
            rospy.logwarn("%s: %s: stopped the base, commands refused until it is back", self.name, why)
        elif was and not on:
            rospy.loginfo("%s: %s is back: commands pass again", self.name, reason)

    def _watch(self) -> None:
        """Wall-clock watchdog (see the module's doc): the clock moving, the dead-man held, status."""
        last_time, last_move = None, time.monotonic()  # wall clock: it watches whether ROS time moves
        next_status = 0.0
        waiting_since = None if self.sim_time else time.monotonic()  # wall; on simulated time: from the first /clock
        while not rospy.is_shutdown():
            wall = time.monotonic()
            if self.silent and self.sensor_wait > 0:
                if waiting_since is None and rospy.get_time() > 0:
                    waiting_since = wall
                if waiting_since is not None and wall - waiting_since > self.sensor_wait:
                    topic, what = sorted(self.silent.items())[0]
                    self.refused = (f"{topic} ({what}) has been silent for {self.sensor_wait:g} s: refusing to "
                                    f"start (check with `subsumption doctor`)")
                    rospy.logerr("%s: %s", self.name, self.refused)
                    rospy.signal_shutdown("a needed sensor is silent")
                    return
            if self.sim_time and self.clock_timeout > 0:
                now = rospy.get_time()
                if now != last_time:
                    last_time, last_move = now, wall
                lost = now == 0.0 or wall - last_move > self.clock_timeout
                self._hold(CLOCK, lost, f"ROS time has not moved for {wall - last_move:.1f} s (clock lost)")
            if self.deadman_timeout > 0:
                out = wall - self._last_deadman > self.deadman_timeout
                self._hold(DEADMAN, out, f"no dead-man signal for {self.deadman_timeout:g} s")
            if self._changed or wall >= next_status:
                self._publish_status()
                next_status = wall + STATUS_PERIOD
            time.sleep(WATCH_PERIOD)

    def _publish_status(self) -> None:
        with self._lock:
            state = self.guard.state()
            self._changed = False
        held = [k for k in ("held", BUMPER, CLIFF, WHEEL_DROP) if state[k] != "-"]
        self._status.publish(DiagnosticStatus(
            level=DiagnosticStatus.WARN if held else DiagnosticStatus.OK, name=self.name,
            message="held: " + "; ".join(f"{k} {state[k]}" for k in held) if held else "commands pass (capped)",
            hardware_id="", values=[KeyValue(k, v) for k, v in state.items()]))


def main(argv: list[str] | None = None) -> int:
    """Run ``rosrun subsumption base_guard _profile:=NAME`` until shutdown; exit status 2 on a bad profile."""
    rospy.init_node("base_guard", argv=argv)
    try:
        node = BaseGuardNode()
    except ProfileError as error:
        print(f"base_guard: {error}", file=sys.stderr)
        return 2
    rospy.spin()
    if node.refused:
        print(f"{node.name}: {node.refused}", file=sys.stderr)
        return 2
    return 0


__all__ = ["BaseGuardNode", "main"]
