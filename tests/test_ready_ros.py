"""A run starts its simulation only when the network is ready: every node registered and every module built.

A module node registers with the master at once, but its module's setup can take seconds more on a loaded
machine (move_base warms its numba kernels, amcl reads its map); a run that started the simulation on
registration alone had the robot driving before move_base answered. Here a module whose setup takes 8 s:
the wait names it as not built while it sets up, and returns once it is."""
from __future__ import annotations

import os
import time

import pytest
import rosgraph
from conftest import ROOT, ProcessGroup, ros_env

from subsumption.ros.launch import Launched
from subsumption.ros.master import start_master
from subsumption.ros.replay import ReplayError, wait_for_nodes


def _diagnostics_publishers(uri: str) -> set[str]:
    publishers, _, _ = rosgraph.Master("/test_ready", master_uri=uri).getSystemState()
    return next((set(nodes) for topic, nodes in publishers if topic == "/diagnostics"), set())


@pytest.mark.timeout(90)
def test_the_wait_names_a_module_still_setting_up_and_returns_once_it_is_built(tmp_path, monkeypatch):
    master = start_master()
    group = ProcessGroup(dict(ros_env(master.uri), PYTHONPATH=str(ROOT / "tests")), tmp_path)
    try:
        monkeypatch.setitem(os.environ, "ROS_MASTER_URI", master.uri)  # the wait asks this master
        slow = Launched(group.start([str(ROOT / "nodes" / "module"), "__name:=slow",
                                     "_class:=faulty_modules:SlowSetup", "_seconds:=8.0"]), tmp_path / "none")
        started = time.monotonic()
        wait_for_nodes(["slow"], slow, timeout=60.0)  # registered (what the wait used to take for ready) ...
        with pytest.raises(ReplayError, match=r"/slow \(module not built yet\)"):  # ... but still setting up
            wait_for_nodes(["slow"], slow, timeout=1.0, built=["slow"])
        assert "/slow" not in _diagnostics_publishers(master.uri)
        wait_for_nodes(["slow"], slow, timeout=60.0, built=["slow"])
        assert "/slow" in _diagnostics_publishers(master.uri) and time.monotonic() - started >= 8.0
    finally:
        group.stop_all()
        master.stop()
