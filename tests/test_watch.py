"""`subsumption watch` without a running graph, or with a broken file: one clear line each. (The live view of a
running network is tested with the network that tests/test_diagnostics_ros.py starts.)"""
from __future__ import annotations

from conftest import ROOT

from subsumption import cli
from subsumption.ros.master import free_port

EXAMPLE = ROOT / "subsumption" / "examples" / "avoid_demo.yaml"


def test_no_master_is_one_clear_line(monkeypatch, capsys):
    uri = f"http://127.0.0.1:{free_port()}/"
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    assert cli.main(["watch", str(EXAMPLE), "--once", "0"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and err.splitlines() == [
        f"subsumption watch: no ROS master at {uri} (start the network first, or set ROS_MASTER_URI)"]


def test_a_broken_network_file_is_reported_like_check(tmp_path, capsys):
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: x\nlevels: 3\n")
    assert cli.main(["watch", str(broken)]) == 1
    assert f"{broken}:2: levels: expected a list, got 3" in capsys.readouterr().err.splitlines()


def test_no_file_and_no_monitor_running_is_one_line_and_status_2(ros_master, monkeypatch, capsys):
    monkeypatch.setenv("ROS_MASTER_URI", ros_master["ROS_MASTER_URI"])
    assert cli.main(["watch", "--once", "0"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.splitlines() == [
        f"subsumption watch: no network monitor runs on the master at {ros_master['ROS_MASTER_URI']}: give the "
        f"network file (subsumption watch FILE)"]
