"""Module parameters on a real (private) master: a bad value ends the node with one line naming the parameter,
defaults reach the parameter server, and dynamic_reconfigure changes a running node (through the same client
rqt_reconfigure uses, driven by `subsumption reconfigure`)."""
from __future__ import annotations

import subprocess
import time

import pytest
import rosgraph
from conftest import ROOT, VENV_BIN, output_of

MODULE = str(ROOT / "nodes" / "module")
CLI = str(VENV_BIN / "subsumption")


def run(env, *args: str, timeout: float = 20) -> subprocess.CompletedProcess:
    return subprocess.run(list(args), env=env, capture_output=True, text=True, timeout=timeout)


def param(env, name: str):
    """A parameter's value straight from the master (XML-RPC: no node, no process)."""
    return rosgraph.Master("/test_params", master_uri=env["ROS_MASTER_URI"]).getParam(name)


def wait_for_topic(env, topic: str, process, timeout: float = 20.0) -> None:
    """Until `topic` is advertised (the node is then past writing its parameters)."""
    master = rosgraph.Master("/test_params", master_uri=env["ROS_MASTER_URI"])
    deadline = time.monotonic() + timeout  # wall clock: a process starting
    while time.monotonic() < deadline:
        assert process.poll() is None, output_of(process)
        if topic in {name for name, _ in master.getPublishedTopics("/")}:
            return
        time.sleep(0.2)
    raise AssertionError(f"{topic} never appeared: {output_of(process)}")


def headings(env, count: int = 2) -> list[float]:
    got = run(env, "rostopic", "echo", "-n", str(count), "/wander/heading")
    return [float(line.split(":")[1]) for line in got.stdout.splitlines() if line.startswith("data:")]


@pytest.mark.timeout(60)
def test_a_bad_value_ends_the_node_naming_the_parameter(ros_processes):
    node = ros_processes.start([MODULE, "__name:=wander", "_class:=robots.wander.level1:Wander", "_interval:=abc"])
    assert node.wait(timeout=30) == 2
    text = output_of(node)
    assert "/wander: error: /wander/interval must be a number, got 'abc' (str)" in text
    assert "Traceback" not in text


@pytest.mark.timeout(90)
def test_defaults_on_the_server_and_reconfigure_a_running_node(ros_processes):
    env = ros_processes.env
    node = ros_processes.start([MODULE, "__name:=wander", "_class:=subsumption.examples.avoid_demo:Wander",
                                "_period:=0.2", "_direction:=1"])
    wait_for_topic(env, "/wander/parameter_updates", node)  # the reconfigure server starts after the check
    direction = param(env, "/wander/direction")
    assert direction == 1.0 and isinstance(direction, float)  # typed: an int given for a float
    assert param(env, "/wander") == {"class": "subsumption.examples.avoid_demo:Wander", "period": 0.2,
                                     "direction": 1.0}

    changed = run(env, CLI, "reconfigure", "/wander", "direction=-0.5")
    assert changed.returncode == 0, changed.stderr
    assert "/wander/direction: -0.5" in changed.stdout.splitlines()
    assert param(env, "/wander/direction") == -0.5

    refused = run(env, CLI, "reconfigure", "/wander", "period=-1")  # the module cannot run with it
    assert refused.returncode == 1 and "/wander/period: 0.2  (refused: see the node's log)" in refused.stdout
    assert param(env, "/wander/period") == 0.2
    assert "reconfigure refused: /wander/period: refused, the module failed" in output_of(node)

    wrong = run(env, CLI, "reconfigure", "/wander", "direction=abc")
    assert wrong.returncode == 1 and "Traceback" not in wrong.stderr
    assert "can't set parameter 'direction'" in wrong.stderr.strip().splitlines()[-1]
    # the node sends the new direction, and kept running through the refusal
    assert headings(env, 3) == [-0.5, -0.5, -0.5]
