"""``subsumption doctor [--profile P] [--robot wander|patrol] [--level N]``: before anything drives, listen to what
the chosen robot's network needs from the base and say, one line each, what is missing, of the wrong type, in the
wrong frame, silent, slow, stale, or on a clock that does not move.

It reads the profile (:mod:`subsumption.profile`): every topic the robot needs at that level, with its type,
frame and nominal rate, the base's velocity input (someone must subscribe to it: the driver) and its event
topics. It asks the master who publishes what, then listens ``--listen`` wall seconds to every needed topic (and
``/clock`` on simulated time). Exit status: 0 all fine, 1 a problem found, 2 no master or a bad profile.
"""
from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass, field

from ..profile import Profile, TopicSpec


@dataclass
class Heard:
    """What arrived on one topic while listening (wall times, ROS stamps)."""
    count: int = 0
    first: float = 0.0
    last: float = 0.0
    frames: set[str] = field(default_factory=set)
    children: set[str] = field(default_factory=set)
    last_stamp: float | None = None

    def add(self, msg) -> None:
        """Count a message heard on the topic, at the wall clock's now (rates as a user at the robot sees them), keeping
        its stamp."""
        now = time.monotonic()  # wall clock: rates are judged as a user at the robot sees them
        self.first = self.first or now
        self.last = now
        self.count += 1
        header = getattr(msg, "header", None)
        if header is not None:
            self.frames.add(header.frame_id)
            self.last_stamp = header.stamp.to_sec()
        child = getattr(msg, "child_frame_id", None)
        if child is not None:
            self.children.add(child)

    def rate(self) -> float | None:
        """Messages per second heard so far, or None before three have come."""
        return (self.count - 1) / (self.last - self.first) if self.count >= 3 and self.last > self.first else None


def judge(spec: TopicSpec, published: str | None, heard: Heard | None, listen: float, base_frame: str,
          ros_now: float | None) -> list[str]:
    """The problems of one needed topic, one line each (none: it is fine)."""
    if published is None:
        return [f"MISSING {spec.topic}: nobody publishes it ({spec.type} expected)"]
    if published != spec.type:
        return [f"WRONG TYPE {spec.topic}: {published}, expected {spec.type}"]
    if spec.rate <= 0:
        return []  # an event topic: advertised with the right type is all that can be asked
    problems = []
    if heard is None or heard.count == 0:
        return [f"SILENT {spec.topic}: advertised, but no message in {listen:g} s (about {spec.rate:g} Hz expected)"]
    rate = heard.rate()
    if rate is not None and rate < 0.5 * spec.rate:
        problems.append(f"SLOW {spec.topic}: {rate:.1f} Hz, expected about {spec.rate:g} Hz")
    wrong = sorted(f for f in heard.frames if spec.frame and f.lstrip("/") != spec.frame)
    if wrong:
        problems.append(f"WRONG FRAME {spec.topic}: frame_id '{wrong[0]}', expected '{spec.frame}'")
    children = sorted(c for c in heard.children if c.lstrip("/") != base_frame)
    if children:
        problems.append(f"WRONG FRAME {spec.topic}: child_frame_id '{children[0]}', expected '{base_frame}'")
    if ros_now is not None and heard.last_stamp is not None and heard.last_stamp > 0:
        age = ros_now - heard.last_stamp
        if age > max(1.0, 3.0 / spec.rate):
            problems.append(f"STALE {spec.topic}: its last message is stamped {age:.1f} s behind the clock")
    return problems


def doctor(profile: Profile, robot: str, level: int, listen: float, out=sys.stdout) -> int:
    """Listen `listen` seconds to the graph and print one line per missing, mistyped, silent, slow or stale topic the
    profile's `robot` needs at `level`; the exit status."""
    import rosgraph
    import roslib.message
    import rospy
    from rosgraph_msgs.msg import Clock

    master = rosgraph.Master("/subsumption_doctor")
    try:
        published = dict(master.getPublishedTopics("/"))
        _, subscribers, _ = master.getSystemState()
    except Exception as error:  # the master is not there (socket errors, a refused connection)
        print(f"subsumption doctor: no ROS master at {rosgraph.get_master_uri()} ({error})", file=sys.stderr)
        return 2
    needed = profile.needed(robot, level)
    print(f"doctor: profile {profile.name} ({profile.path}), the {robot} robot at level {level}: "
          f"{len(needed)} topics, listening {listen:g} s", file=out)
    rospy.init_node("subsumption_doctor", anonymous=True, disable_signals=True)
    heard: dict[str, Heard] = {}
    lock = threading.Lock()
    subs = []
    for spec in needed:
        if published.get(spec.topic) == spec.type and spec.rate > 0:
            cls = roslib.message.get_message_class(spec.type)
            heard[spec.topic] = Heard()
            subs.append(rospy.Subscriber(spec.topic, cls, lambda m, h=heard[spec.topic]: _locked(lock, h.add, m)))
    sim_time = bool(rospy.get_param("/use_sim_time", False))
    clock_values: list[float] = []
    if sim_time and "/clock" in published:
        subs.append(rospy.Subscriber("/clock", Clock, lambda m: clock_values.append(m.clock.to_sec())))
    time.sleep(listen)  # wall clock: listening is done in the user's time
    for sub in subs:
        sub.unregister()
    problems = []
    ros_now = clock_values[-1] if sim_time and clock_values else (None if sim_time else rospy.get_time())
    for spec in needed:
        lines = judge(spec, published.get(spec.topic), heard.get(spec.topic), listen, profile.base_frame, ros_now)
        problems += lines
        for line in lines:
            print(line, file=out)
        if not lines:
            h = heard.get(spec.topic)
            rate = h.rate() if h else None
            detail = (f"{rate:.1f} Hz" if rate else "speaks on events only") + (
                f", frame {sorted(h.frames)[0]}" if h and h.frames else "")
            print(f"OK {spec.topic}: {spec.type}, {detail}", file=out)
    if sim_time:
        if "/clock" not in published:
            problems.append("CLOCK /clock: /use_sim_time is set but nobody publishes /clock")
        elif not clock_values:
            problems.append(f"CLOCK /clock: advertised, but no message in {listen:g} s")
        elif clock_values[-1] <= clock_values[0]:
            problems.append(f"CLOCK /clock: does not move (stuck at {clock_values[-1]:.2f} s)")
        if problems and problems[-1].startswith("CLOCK"):
            print(problems[-1], file=out)
    drivers = [nodes for topic, nodes in subscribers if topic == profile.cmd_vel]
    if not drivers:
        line = f"MISSING {profile.cmd_vel}: nobody subscribes to the base's velocity input (is the driver up?)"
        problems.append(line)
        print(line, file=out)
    print(f"doctor: {len(problems)} problem{'s' if len(problems) != 1 else ''}" if problems else
          "doctor: everything the robot needs is there", file=out)
    return 1 if problems else 0


def _locked(lock: threading.Lock, fn, msg) -> None:
    with lock:
        fn(msg)


__all__ = ["doctor", "judge", "Heard"]
