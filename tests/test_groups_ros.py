"""Module groups on a private master: in-process wires deliver the same message object, an arbiter inside a
group keeps its rule and time constant, every wire stays visible outside (and costs nothing there until
someone subscribes), the group reports its members, and a killed group takes only its own level with it:
the level below drives on through the arbiter on its line, and the group respawns as one.

One network serves every test of this file (starting it is the slow part), launched with ``--groups file``:
group ``base`` is level 0 (a counter read by two witnesses; a line of its own with an arbiter whose two lines
are both in the group; the motor line), group ``top`` is level 1 (a pulse suppressing the motor line through an
arbiter that lives in ``base``, with the line it sits on), marked respawn."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import xmlrpc.client

import pytest
import rosgraph
from conftest import ROOT, VENV_BIN, ProcessGroup, output_of, ros_env

from subsumption.ros.master import start_master

T = 1.0  # both arbiters' time constant, s
SLACK = 0.3  # s: how late a message may be handled on a loaded machine, for the checks of the rule below

NETWORK = f"""
name: grouptest
external:
  out: std_msgs/Float64
  inner: std_msgs/Float64
  same1: std_msgs/Bool
  same2: std_msgs/Bool
levels:
  - name: base
    group: base
    modules:
      - {{name: count, class: "group_modules:Count"}}
      - {{name: w1, class: "group_modules:Witness", inputs: {{count: count.count}}, outputs: {{same: same1}}}}
      - {{name: w2, class: "group_modules:Witness", inputs: {{count: count.count}}, outputs: {{same: same2}}}}
      - {{name: lower, class: "group_modules:Pulse", params: {{sign: -1.0}}}}
      - {{name: motor, class: "group_modules:Relay", inputs: {{value: lower.out}}, outputs: {{out: out}}}}
      - {{name: inner_upper, class: "group_modules:Pulse", params: {{sign: 1.0, width: 1.5, gap: 2.5}}}}
      - {{name: inner, class: "group_modules:Relay", inputs: {{value: lower.out}}, outputs: {{out: inner}}}}
    arbiters:
      - {{kind: suppressor, name: inside, upper: inner_upper.out, lower: inner.value, time_constant: {T}}}
  - name: top
    group: top
    modules:
      - {{name: upper, class: "group_modules:Pulse", params: {{sign: 1.0}}, respawn: true, respawn_delay: 2.0}}
    arbiters:
      - {{kind: suppressor, name: over, upper: upper.out, lower: motor.value, time_constant: {T}}}
"""

# Subscribes to topics for a while; prints {topic: [[receive wall time, value], ...]} as JSON (a diagnostics
# array's value: {status name: {key: value}}). A topic given as TOPIC:TYPE? is optional: not waited for.
COLLECT = """
import json, sys, time, rospy
from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import Bool, Float64, Int64
rospy.init_node("collect", anonymous=True)
types = {"Bool": Bool, "Float64": Float64, "Int64": Int64, "DiagnosticArray": DiagnosticArray}
value = lambda m: m.data if hasattr(m, "data") else {s.name: {kv.key: kv.value for kv in s.values} for s in m.status}
seen, awaited = {}, []
for arg in sys.argv[2:]:
    topic, kind = arg.split(":")
    seen[topic] = []
    if not kind.endswith("?"):
        awaited.append(topic)
    rospy.Subscriber(topic, types[kind.rstrip("?")], lambda m, t=topic: seen[t].append([time.time(), value(m)]),
                     queue_size=100)
while not all(seen[t] for t in awaited):  # every topic awaited heard: say so (on stderr), then listen
    time.sleep(0.05)
print("listening", file=sys.stderr, flush=True)
time.sleep(float(sys.argv[1]))
print(json.dumps(seen))
"""


def collect(env: dict, seconds: float, *topics: str) -> dict[str, list]:
    done = subprocess.run([sys.executable, "-c", COLLECT, str(seconds), *topics], env=env, capture_output=True,
                          text=True, timeout=seconds + 30)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def pid_of(env: dict, node: str) -> int | None:
    try:
        master = rosgraph.Master("/test_groups", master_uri=env["ROS_MASTER_URI"])
        code, _, pid = xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid("/test_groups")
        return pid if code == 1 else None
    except Exception:  # not registered (yet), or its registration points at a dead process
        return None


@pytest.fixture(scope="module")
def network(tmp_path_factory):
    folder = tmp_path_factory.mktemp("groups")
    path = folder / "grouptest.yaml"
    path.write_text(NETWORK)
    master = start_master()
    env = dict(ros_env(master.uri), PYTHONPATH=str(ROOT / "tests"))
    processes = ProcessGroup(env, folder)
    try:
        launch = processes.start([str(VENV_BIN / "subsumption"), "launch", str(path), "--groups", "file",
                                  "--xml", str(folder / "grouptest.launch")])
        deadline = time.monotonic() + 90  # wall clock: processes starting (slow on a loaded machine)
        while time.monotonic() < deadline and not (pid_of(env, "/base") and pid_of(env, "/top")):
            assert launch.poll() is None, output_of(launch)
            time.sleep(0.5)
        assert pid_of(env, "/base") and pid_of(env, "/top"), output_of(launch)
        time.sleep(1.0)  # the lines flowing
        # nobody outside reads /count/count yet: the group holds no connection for it (nothing is serialized)
        graph = rosgraph.Master("/test_groups", master_uri=env["ROS_MASTER_URI"])
        bus = xmlrpc.client.ServerProxy(graph.lookupNode("/base")).getBusInfo("/test_groups")[2]
        # one listener for the first tests: starting a ROS node is slow on a loaded machine
        # the witness second to see a count speaks: w2, the later reader, unless w1's turn came after it
        seen = collect(env, 6.0, "/same1:Bool?", "/same2:Bool", "/inner:Float64", "/count/count:Int64",
                       "/lower/out:Float64", "/diagnostics:DiagnosticArray")
        yield env, launch, seen, bus
    finally:
        processes.stop_all()
        master.stop()


def _rule_holds(values: list[float]) -> tuple[int, int, int]:
    """Checks a suppressor's output, whose messages carry +send time (upper) or -send time (lower): no lower
    message within T of the upper one before it (less SLACK), and each return of the lower line comes near T
    after the last upper message. Returns (upper messages, lower messages, returns of the lower line)."""
    last_upper = None
    upper = lower = returns = 0
    for value in values:
        if value > 0:
            upper += 1
            last_upper = value
            continue
        lower += 1
        if last_upper is not None:
            gap = -value - last_upper
            assert gap >= T - SLACK, f"lower sent {gap:.3f} s after upper passed the suppressor (T = {T} s)"
            assert gap <= T + 1.5, f"lower came back only {gap:.3f} s after the last upper message (T = {T} s)"
            returns += 1
            last_upper = None
    return upper, lower, returns


@pytest.mark.timeout(120)
def test_inside_a_group_the_same_object_reaches_every_reader(network):
    seen = network[2]
    verdicts = [value for topic in ("/same1", "/same2") for _, value in seen[topic]]
    assert len(verdicts) >= 10, seen  # one per count message (10/s), by whichever witness saw it second
    assert all(verdicts), "a witness got a copy, not the object the other one got"


@pytest.mark.timeout(120)
def test_an_arbiter_inside_a_group_keeps_its_rule_and_time_constant(network):
    seen = network[2]
    upper, lower, returns = _rule_holds([value for _, value in seen["/inner"]])
    assert upper >= 10 and lower >= 10 and returns >= 1, (upper, lower, returns)


@pytest.mark.timeout(120)
def test_every_wire_is_visible_outside_and_sent_only_on_demand(network):
    env, _, seen, bus = network
    master = rosgraph.Master("/test_groups", master_uri=env["ROS_MASTER_URI"])
    publishers = {topic: nodes for topic, nodes in master.getSystemState()[0]}
    for topic in ("/count/count", "/lower/out", "/inner_upper/out", "/inside/output", "/upper/out", "/out"):
        assert publishers.get(topic) == ["/top" if topic == "/upper/out" else "/base"], (topic, publishers)
    assert not [c for c in bus if c[4] == "/count/count"], bus  # before anyone outside subscribed
    counts = [value for _, value in seen["/count/count"]]
    assert len(counts) >= 5 and counts == sorted(counts), counts
    assert seen["/lower/out"] and all(value < 0 for _, value in seen["/lower/out"])


@pytest.mark.timeout(120)
def test_a_group_reports_its_members(network):
    env, _, seen, _ = network
    master = rosgraph.Master("/test_groups", master_uri=env["ROS_MASTER_URI"])
    assert set(master.getParam("/base/hosts")) == {"/count", "/w1", "/w2", "/lower", "/motor", "/inner_upper",
                                                   "/inner", "/inside", "/over"}
    names: dict = {}
    for _, statuses in seen["/diagnostics"]:
        names.update(statuses)
    assert names["/top"]["members"] == "/upper"  # its arbiter lives with the line it sits on, in base
    assert "/over" in names["/base"]["members"] and "/count" in names["/base"]["members"]
    assert {"/count", "/w1", "/inside", "/over", "/upper"} <= set(names), names  # each member under its own name


def test_members_share_the_group_s_workers_and_report_their_cpu(network):
    """The members' callbacks run on the group's two worker threads (named after the group for `top -H`), not a
    thread each; since `top -H` can no longer tell the members apart, each reports its callbacks' CPU."""
    env, _, seen, _ = network
    pid = pid_of(env, "/base")
    assert pid is not None
    names = []
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/comm") as comm:
                names.append(comm.read().strip())
        except FileNotFoundError:  # a short-lived thread (rospy's, for a connection) ended after the listing
            continue
    assert names.count("base") == 2, names  # the workers; nine members, no thread of their own
    assert not {"count", "w1", "inside", "over"} & set(names), names
    statuses: dict = {}
    for _, names_seen in seen["/diagnostics"]:
        statuses.update(names_seen)
    assert statuses["/base"]["workers"] == "2"
    assert int(statuses["/base"]["workers_woken"]) > 0  # messages from outside and timer ticks wake them
    for member in ("/count", "/w1", "/inside", "/over"):
        assert float(statuses[member]["cpu_s"]) > 0, statuses[member]  # each has run callbacks by now
        assert 0 <= float(statuses[member]["cpu_percent"]) < 100, statuses[member]
        assert statuses[member]["pid"] == str(pid)  # counted by the group's process


@pytest.mark.timeout(120)
def test_a_killed_group_leaves_the_level_below_driving_and_respawns_as_one(network):
    """Level 1's process killed: the suppressor on level 0's motor line lives in level 0's group, so level 0
    drives on through it; roslaunch starts level 1 again, all of it, in one new process."""
    env, launch = network[:2]
    listener = subprocess.Popen([sys.executable, "-c", COLLECT, "4.0", "/out:Float64"], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert listener.stderr.readline().strip() == "listening"
        time.sleep(0.5)
        old = pid_of(env, "/top")
        os.kill(old, signal.SIGKILL)  # our own child's child: roslaunch started it for this test's launch
        killed = time.time()
        out, _ = listener.communicate(timeout=60)
    finally:
        if listener.poll() is None:
            listener.kill()
            listener.wait()
    after = [value for _, value in json.loads(out)["/out"]]
    assert any(0 < value < killed for value in after), "level 1 should be driving before the kill"
    # every message says when it was sent (ROS time is the wall clock here): level 0's line, from T after the
    # kill until the new process's first message, is what drives the motor line
    back = min([value for value in after if value > killed] + [float("inf")])
    gap = [value for value in after if killed + T + SLACK < -value < back]
    assert gap, after
    _rule_holds(after)
    deadline = time.monotonic() + 30  # wall clock: respawn_delay 2 s and the process starting
    while time.monotonic() < deadline and pid_of(env, "/top") in (None, old):
        assert launch.poll() is None, output_of(launch)
        time.sleep(0.5)
    assert pid_of(env, "/top") not in (None, old)
    deadline = time.monotonic() + 30
    again: list = []
    while time.monotonic() < deadline and not any(value > 0 for _, value in again):
        again = collect(env, 2.0, "/out:Float64")["/out"]
    assert any(value > 0 for _, value in again), "level 1 should drive again once its group is back"


@pytest.mark.timeout(120)
def test_a_publisher_outside_is_heard_and_a_wrong_type_refused(network):
    """Outside publishers of a line the group writes still reach its readers (the group only skips its own
    connection); one of the wrong type is refused per connection and counted in the reader's diagnostics."""
    env = network[0]
    publishers = [subprocess.Popen(["rostopic", "pub", "-r", "10", "/lower/out", kind, data], env=env,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                  for kind, data in (("std_msgs/String", "data: hello"), ("std_msgs/Float64", "data: 7777.0"))]
    try:
        seen = collect(env, 4.5, "/diagnostics:DiagnosticArray", "/inner:Float64")
    finally:
        for publisher in publishers:
            publisher.terminate()
            publisher.wait(10)
    statuses: dict = {}
    for _, names in seen["/diagnostics"]:
        statuses.update(names)
    # /lower/out is read in the group by the two arbiters on it (over, inside): both refuse the strings
    assert int(statuses["/over"]["refused"]) > 0 and int(statuses["/inside"]["refused"]) > 0, statuses["/over"]
    inner = [value for _, value in seen["/inner"]]
    assert 7777.0 in inner, inner  # the hand-typed Float64 reached the arbiter inside the group
    assert any(value < 0 for value in inner)  # ... beside the group's own writer


@pytest.mark.timeout(120)
@pytest.mark.parametrize("workers", ["0", "two"])
def test_a_bad_number_of_workers_is_an_error_naming_the_parameter(ros_processes, workers):
    group = ros_processes.start([sys.executable, "nodes/group", "__name:=bad_workers", f"_workers:={workers}",
                                 '_members:=[{name: c, class: "group_modules:Count"}]'])  # refused before built
    assert group.wait(60) == 2, output_of(group)
    assert "/bad_workers/workers: the number of worker threads must be an integer >= 1" in output_of(group)


@pytest.mark.timeout(120)
def test_watch_shows_each_member_s_cpu(network):
    env, launch = network[:2]
    path = next(arg for arg in launch.args if arg.endswith(".yaml"))
    done = subprocess.run([str(VENV_BIN / "subsumption"), "watch", path, "--once", "2"], env=env,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    rows = {line.split()[0]: line.split() for line in done.stdout.splitlines() if line.split()}
    assert rows["MODULE"][:3] == ["MODULE", "HEALTH", "CPU"], rows["MODULE"]
    for member in ("count", "w1", "upper"):
        assert rows[member][1] == "OK" and 0.0 <= float(rows[member][2]) < 100.0, rows[member]
