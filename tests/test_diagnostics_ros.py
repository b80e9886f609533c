"""Health and state of a running network on a private master: every module and arbiter on /diagnostics (a failing
module as ERROR, its timer still running), the monitor's latched arbitration topic, `subsumption watch`, and an
arbiter's time constant changed while it runs.

One network serves every test of this file (starting it is the slow part): the avoid_demo network, levels 0..1,
through `subsumption launch`, and beside it a module whose timer callback raises."""
from __future__ import annotations

import json
import re
import subprocess
import sys
import time

import pytest
from conftest import ROOT, VENV_BIN, ProcessGroup, output_of, ros_env

from subsumption.ros.master import start_master

EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"
MODULES = ["feelforce", "runaway", "turn", "wander", "avoid"]

# Listens to /diagnostics for a while; prints {status name: [level, message, {key: value}]} as JSON.
COLLECT = """
import json, sys, time, rospy
from diagnostic_msgs.msg import DiagnosticArray
rospy.init_node("collect", anonymous=True)
seen = {}
def on(msg):
    for s in msg.status:
        seen.setdefault(s.name, []).append([s.level, s.message, {kv.key: kv.value for kv in s.values}])
rospy.Subscriber("/diagnostics", DiagnosticArray, on)
time.sleep(float(sys.argv[1]))
print(json.dumps(seen))
"""


@pytest.fixture(scope="module")
def network(tmp_path_factory):
    master = start_master()
    env = ros_env(master.uri)
    group = ProcessGroup(env, tmp_path_factory.mktemp("diagnostics_logs"))
    try:
        launch = group.start([str(VENV_BIN / "subsumption"), "launch", str(EXAMPLE), "--level", "1"])
        group.env = dict(env, PYTHONPATH=str(ROOT / "tests"))
        faulty = group.start([str(ROOT / "nodes" / "module"), "__name:=faulty", "_class:=faulty_modules:Faulty"])
        group.env = env
        expected = {f"/{name}" for name in MODULES + ["suppressor_turn_heading", "avoid_demo_monitor", "faulty"]}
        deadline = time.monotonic() + 40  # wall clock: processes starting
        while time.monotonic() < deadline:
            assert launch.poll() is None, output_of(launch)
            running = set(subprocess.run(["rosnode", "list"], env=env, capture_output=True, text=True).stdout.split())
            if expected <= running:
                break
            time.sleep(0.5)
        assert expected <= running, output_of(launch)
        time.sleep(1.0)
        yield env, faulty
    finally:
        group.stop_all()
        master.stop()


@pytest.mark.timeout(60)
def test_every_module_on_diagnostics_and_a_failing_one_as_error(network):
    env, faulty = network
    done = subprocess.run([sys.executable, "-c", COLLECT, "2.5"], env=env, capture_output=True, text=True, timeout=30)
    seen = json.loads(done.stdout)
    for name in MODULES:
        level, message, values = seen[f"/{name}"][-1]
        assert level == 0, (name, message)
        assert values["class"].startswith("subsumption.examples.avoid")
    assert seen["/avoid"][-1][2]["state"] in {"nil", "plan", "go", "start"}  # the AFSM's state
    feelforce = seen["/feelforce"][-1][2]
    assert re.fullmatch(r"/feelforce/force: \d+ msgs, [\d.]+/s", feelforce["out force"])
    assert float(feelforce["cpu_s"]) > 0 and 0 <= float(feelforce["cpu_percent"]) < 100  # its callbacks' CPU
    errors = [entry for entry in seen["/faulty"] if entry[0] == 2]
    assert errors and errors[-1][1].startswith("timer Faulty.tick: ZeroDivisionError: tick ")
    counts = [int(entry[2]["callback errors"]) for entry in seen["/faulty"]]
    assert counts[-1] > counts[0] >= 1  # its timer kept running after the first error
    assert faulty.poll() is None
    arbiter = seen["/suppressor_turn_heading"][-1]
    assert arbiter[0] == 0 and arbiter[2]["kind"] == "suppressor" and arbiter[2]["in_control"] == "upper"
    assert float(arbiter[2]["cpu_s"]) > 0 and 0 <= float(arbiter[2]["cpu_percent"]) < 100  # a node of its own
    assert arbiter[2]["pid"] != feelforce["pid"] and all(p.isdigit() for p in (arbiter[2]["pid"], feelforce["pid"]))
    monitor = seen["/avoid_demo_monitor"][-1]
    assert monitor[2]["network"] == "avoid_demo" and "suppressor_turn_heading" in monitor[2]


@pytest.mark.timeout(60)
def test_arbitration_is_latched_and_names_the_line_in_control(network):
    env, _ = network
    done = subprocess.run(["rostopic", "echo", "-n", "1", "/avoid_demo_monitor/arbitration"], env=env,
                          capture_output=True, text=True, timeout=20)
    # wander sends a heading every second and the suppressor holds 2 s: avoid's line keeps the output
    assert 'message: "suppressor_turn_heading: upper avoid.heading"' in done.stdout


@pytest.mark.timeout(60)
def test_watch_shows_states_holders_and_rates(network):
    env, _ = network
    done = subprocess.run([str(VENV_BIN / "subsumption"), "watch", str(EXAMPLE), "--level", "1", "--once", "3"],
                          env=env, capture_output=True, text=True, timeout=40)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("network avoid_demo") and "levels 0..1" in lines[0]
    rows = {line.split()[0]: line for line in lines if line.split()}
    for name in MODULES:
        assert rows[name].split()[1] == "OK", rows[name]
    assert re.search(r"avoid\s+OK\s+\d+\.\d\s+AFSM state \w+", rows["avoid"])  # its callbacks' CPU, %
    assert re.search(r"suppressor_turn_heading\s+\d+\.\d\s+upper avoid\.heading\s+\d+/0; \d+/\d+",
                     rows["suppressor_turn_heading"])
    force = next(line for line in lines if line.startswith("feelforce.force -> runaway.force"))
    assert "/feelforce/force" in force and 1.0 <= float(force.split()[-1]) <= 3.0  # every 0.5 s
    heading = next(line for line in lines if line.startswith("wander.heading -> avoid.heading"))
    assert 0.5 <= float(heading.split()[-1]) <= 1.5  # every second


@pytest.mark.timeout(60)
def test_watch_without_a_file_asks_the_running_monitor(network):
    """The monitor carries ~network_file and ~level: watch finds it on the master and shows that network."""
    env, _ = network
    done = subprocess.run([str(VENV_BIN / "subsumption"), "watch", "--once", "1"],
                          env=env, capture_output=True, text=True, timeout=40)
    assert done.returncode == 0, done.stderr
    assert f"subsumption watch: {EXAMPLE}, levels 0..1, namespace / (from the running monitor)" in done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith(f"network avoid_demo ({EXAMPLE})") and "levels 0..1" in lines[0]
    assert any(line.startswith("suppressor_turn_heading ") for line in lines)


@pytest.mark.timeout(60)
def test_an_arbiters_time_constant_changes_while_it_runs(network):
    env, _ = network
    cli = str(VENV_BIN / "subsumption")
    done = subprocess.run([cli, "reconfigure", "/suppressor_turn_heading", "time_constant=0.5"], env=env,
                          capture_output=True, text=True, timeout=30)
    assert done.returncode == 0 and "/suppressor_turn_heading/time_constant: 0.5" in done.stdout, done.stderr
    # wander's heading comes once a second: with T = 0.5 s runaway's line gets the output back in between
    status = subprocess.run(["rostopic", "echo", "-n", "3", "/suppressor_turn_heading/status"], env=env,
                            capture_output=True, text=True, timeout=30).stdout
    assert 'value: "0.5"' in status and 'message: "lower line in control"' in status
    refused = subprocess.run([cli, "reconfigure", "/suppressor_turn_heading", "time_constant=0"], env=env,
                             capture_output=True, text=True, timeout=30)
    assert refused.returncode == 1 and "time_constant: 0.5  (refused" in refused.stdout
