"""A module parameter named like another node (bumpturn's `turn`, beside the `turn` module) on dynamic_reconfigure.

Found by bench/chaos after the groups merge: the node served its parameters in the namespace "~", which
dynamic_reconfigure makes "~/" and rospy resolves at the root, so `turn` read the `turn` node's whole namespace (a
dict) and every bumpturn node of the patrol died at start (respawned, died again; the run never became ready).
"""
from __future__ import annotations

import subprocess
import sys
import time

import pytest

from conftest import output_of


@pytest.mark.timeout(120)
def test_a_parameter_named_as_another_node_is_the_modules_own(ros_processes):
    env = ros_processes.env
    subprocess.run(["rosparam", "set", "/turn/gain", "2.0"], env=env, check=True, timeout=30)  # the other node's
    node = ros_processes.start([sys.executable, "nodes/module", "__name:=bumpturn",
                                "_class:=robots.patrol.level1:Bumpturn"])
    end = time.monotonic() + 60  # wall clock: a process starting
    while time.monotonic() < end and "running robots.patrol.level1:Bumpturn" not in output_of(node):
        assert node.poll() is None, output_of(node)
        time.sleep(0.2)
    time.sleep(1.0)
    assert node.poll() is None, output_of(node)
    got = subprocess.run(["rosparam", "get", "/bumpturn/turn"], env=env, capture_output=True, text=True, timeout=30)
    assert got.stdout.strip() == "0.9", got
