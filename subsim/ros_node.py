"""The simulator as a ROS node: ``rosrun subsumption simulator _world:=/path/world.yaml _rate:=1.0``.

The node owns simulated time: it steps the physics, publishes ``/clock`` (every second step) and sets
``/use_sim_time`` (unless told not to), so every node started after it runs on simulated time, like Gazebo
or stdr. It paces itself with the wall clock (the only place in the project where the wall clock decides
anything): ``~rate: 1.0`` is real time, ``3.0`` three times faster, ``0`` as fast as it can.

Parameters (private, or the same names as ``--options`` on the command line; the command line wins):
``~world`` (a world YAML; default: the shipped room), ``~rate``, ``~physics_rate`` (Hz, 50),
``~sensor_rate`` (Hz, 10), ``~clock_rate`` (Hz of ``/clock``, 25: every
second physics step; it is published on every round(physics_rate / clock_rate)-th step. Every node's timers
run on it, so it must resolve the graph's shortest timer period, amcl's 0.05 s; 0 = every physics step. Each
message wakes every timer thread of every node: at 50 Hz the patrol robot's ~36 nodes spent about half a core
of the 2-core machine on it, ``bench/clock_cost``), ``~camera_rate`` (Hz of every robot's camera frames, as
a Kinect driver's ``data_skip`` sets it; 0 = each camera's ``rate`` in the world file), ``~seed`` (0),
``~duration`` (simulated seconds, 0 = until shut down),
``~set_use_sim_time`` (true), ``~connect_wait`` (wall s, 5: before the first step the node waits until every
node the master lists on its topics is connected to it, at most this long; 0 = start at once), ``~map_to_odom``
(true: publish the true ``map -> odom``; false when a localizer or SLAM publishes it), ``~publish_map`` (true: the
world's map on ``/map``; false under SLAM).

This is the only module of subsim that imports rospy.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any, NamedTuple

import rospy

from subsumption.ros.runtime import RosNodeHandle, start_node

from . import world_path
from .bridge import SimBridge
from .sim import Simulation
from .world import WorldError
from .mapio import MapError

DEFAULTS: dict[str, Any] = {"world": str(world_path("room")), "rate": 1.0, "physics_rate": 50.0,
                            "sensor_rate": 10.0, "clock_rate": 25.0, "camera_rate": 0.0, "seed": 0,
                            "duration": 0.0,
                            "set_use_sim_time": True, "connect_wait": 5.0,
                            "map_to_odom": True, "publish_map": True}
QUEUE = 100  # a sweep publishes 12 sonar messages at once: the publisher queue must hold them all


def _command_line(argv: list[str]) -> argparse.Namespace:
    """The --options (parsed before the node starts, so that --help needs no master)."""
    parser = argparse.ArgumentParser(prog="simulator", description=__doc__.split("\n\n")[0],
                                     epilog="Each option may also be given as a private parameter: _world:=...")
    for key, default in DEFAULTS.items():
        kind = (lambda s: s.lower() in ("1", "true", "yes")) if isinstance(default, bool) else type(default)
        parser.add_argument("--" + key.replace("_", "-"), dest=key, type=kind, default=None,
                            help=f"default {default!r}")
    return parser.parse_args(argv)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """Private parameters, overridden by the --options given on the command line."""
    options = {}
    for key, default in DEFAULTS.items():
        given = getattr(args, key)
        options[key] = given if given is not None else type(default)(rospy.get_param("~" + key, default))
    return options


BEHIND_S = 0.25  # wall s the simulation may lag its pace before it carries on from there instead of rushing


class Paced(NamedTuple):
    """What :func:`run` did: simulated and wall seconds, and how often (and by how much in all) it fell more than
    :data:`BEHIND_S` behind its rate and carried on from there: wall time it never made up."""

    simulated: float
    wall: float
    falls: int
    lost: float


def run(bridge: SimBridge, rate: float, duration: float) -> Paced:
    """Step until shutdown (or `duration` simulated seconds), keeping simulated time at `rate` x wall time. A machine
    too slow for `rate` makes the simulation fall behind; past :data:`BEHIND_S` it carries on from where it is (the
    robot's nodes never see time rush to catch up) and says so."""
    sim_start, wall_start = bridge.sim.time, time.monotonic()
    anchor_sim, anchor_wall = sim_start, wall_start
    falls, lost, warned = 0, 0.0, -math.inf
    while not rospy.is_shutdown():
        bridge.step()
        elapsed = bridge.sim.time - sim_start
        if duration > 0 and elapsed >= duration - 1e-9:
            break
        if rate > 0:
            delay = anchor_wall + (bridge.sim.time - anchor_sim) / rate - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -BEHIND_S:
                falls, lost = falls + 1, lost - delay
                anchor_sim, anchor_wall = bridge.sim.time, time.monotonic()
                if anchor_wall - warned >= 10.0:  # at most one warning every 10 wall s
                    warned = anchor_wall
                    rospy.logwarn(f"simulator: {-delay:.2f} s behind {rate:g}x real time at simulated {elapsed:.1f} s "
                                  "(the machine cannot keep up): carrying on from here")
    return Paced(bridge.sim.time - sim_start, time.monotonic() - wall_start, falls, lost)


def unconnected() -> dict[str, tuple[int, int]]:
    """The simulator's topics that the master lists more nodes on than this node is connected to: topic ->
    (connected, listed). Its publications count the subscribers, its subscriptions (cmd_vel) the publishers."""
    import rosgraph
    from rospy.impl.registration import get_topic_manager

    me = rospy.get_name()
    try:
        publishers, subscribers, _ = rosgraph.Master(me).getSystemState()
    except (OSError, rosgraph.MasterException) as error:
        rospy.logwarn("could not ask the master who is on the simulator's topics (%s): not waiting", error)
        return {}
    listed = {"pub": {t: len(set(n) - {me}) for t, n in subscribers},
              "sub": {t: len(set(n) - {me}) for t, n in publishers}}
    manager = get_topic_manager()
    missing = {}
    for kind, impls in (("pub", manager.pubs), ("sub", manager.subs)):
        for topic, impl in list(impls.items()):
            connected, wanted = impl.get_num_connections(), listed[kind].get(topic, 0)
            if connected < wanted:
                missing[topic] = (connected, wanted)
    return missing


def wait_for_connections(timeout: float) -> None:
    """Waits (wall time, at most `timeout` s) until every node already on the simulator's topics is connected.
    A graph started before the simulator (experiments.runner) connects to it only after it has registered its
    topics: 0.9-1.5 s of wall time for the patrol robot's 36 nodes at load 2-12. Stepping at once, the first 1.2 s of
    the scene ran with nobody listening (no clock, odometry or scan: amcl's first scan stamped 1.08 s against
    0.14 s in-process, the patrol's first goal at 2.16 s against 1.0 s, the robot standing still where the
    lower levels drive it from 0.1 s in-process), so the ROS graph and the in-process runtime ran different
    schedules."""
    start = time.monotonic()
    missing = unconnected()
    while missing and not rospy.is_shutdown() and time.monotonic() - start < timeout:
        time.sleep(0.05)
        missing = unconnected()
    if missing:
        rospy.logwarn("starting with nodes not yet connected after %.1f s (topic: connected/listed): %s", timeout,
                      ", ".join(f"{t} {c}/{w}" for t, (c, w) in sorted(missing.items())))
    elif time.monotonic() - start > 0.1:
        rospy.loginfo("every node on the simulator's topics connected after %.2f s", time.monotonic() - start)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    args = _command_line(rospy.myargv(argv)[1:])
    start_node("simulator", argv=argv)  # the full argv: it holds the _param:=value settings
    options = _options(args)
    if options["set_use_sim_time"] and not rospy.has_param("/use_sim_time"):
        rospy.set_param("/use_sim_time", True)
    try:
        sim = Simulation(options["world"], seed=int(options["seed"]), record=False)
    except (WorldError, MapError, ValueError) as exc:
        rospy.logfatal(str(exc))
        print(f"simulator: {exc}", file=sys.stderr)
        return 2
    bridge = SimBridge(RosNodeHandle(queue_size=QUEUE), sim, options["physics_rate"], options["sensor_rate"],
                       start_time=0.0, publish_clock=True, map_to_odom=bool(options["map_to_odom"]),
                       publish_map=bool(options["publish_map"]),
                       clock_rate=float(options["clock_rate"]) or None,
                       camera_rate=float(options["camera_rate"]) or None)
    rospy.loginfo("simulating %s at rate %s (0 = as fast as possible)", options["world"], options["rate"])
    if options["connect_wait"] > 0:
        wait_for_connections(float(options["connect_wait"]))
    paced = run(bridge, float(options["rate"]), float(options["duration"]))
    factor = paced.simulated / paced.wall if paced.wall > 0 else float("inf")
    times = "once" if paced.falls == 1 else f"{paced.falls} times"
    behind = f"; fell behind its rate {times}, {paced.lost:.2f} wall s not made up" if paced.falls else ""
    print(f"simulator: simulated {paced.simulated:.2f} s in {paced.wall:.2f} s wall: {factor:.1f}x real time{behind}",
          flush=True)
    rospy.signal_shutdown("simulation finished")
    duration = float(options["duration"])
    # 0 only when the simulation ran its whole duration (or had none): a run harness reads the status, not the clock
    # its last message carried, to tell a finished simulation from one that stopped short
    return 0 if duration <= 0 or paced.simulated >= duration - 1e-6 else 3
