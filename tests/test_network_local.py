"""The example network in-process: level 0 runs away from the force; at level 1 avoid's heading takes turn over."""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Twist
from test_network_files import EXAMPLE, LEVEL0, write

from subsumption.local import LocalRuntime
from subsumption.network import NetworkInvalid, build_local, load


def run(level: int, seconds: float = 6.0, namespace: str = "/"):
    runtime = LocalRuntime()
    built = build_local(load(EXAMPLE), runtime, level, namespace=namespace)
    turns: list[tuple[float, float]] = []
    topic = "/cmd_vel" if namespace == "/" else f"{namespace}/cmd_vel"
    runtime.node("motors").subscribe(topic, Twist, lambda msg: turns.append((runtime.now(), msg.angular.z)))
    runtime.run_for(seconds)
    return built, turns


def test_level0_runs_away_from_the_force():
    built, turns = run(0)
    assert sorted(built.modules) == ["feelforce", "runaway", "turn"] and built.arbiters == {}
    assert len(turns) == 12  # a force every 0.5 s, each a runaway heading and a command
    assert all(z == pytest.approx(math.pi / 2) for _, z in turns)  # force (0, 1): straight along it


def test_level1_suppressor_takes_over():
    built, turns = run(1)
    suppressor = built.arbiters["suppressor_turn_heading"]
    # Before wander's first heading (t = 1 s) runaway still steers; from then on avoid does (pi/4 = heading 0
    # plus force (0, 1)), as wander speaks every 1 s, well within the suppressor's 2 s.
    assert [z for t, z in turns if t < 1.0] == [pytest.approx(math.pi / 2)]
    after = [z for t, z in turns if t >= 1.0]
    assert after and all(z == pytest.approx(math.pi / 4) for z in after)
    assert suppressor.rule.upper.passed == 6 and suppressor.rule.lower.dropped >= 9
    assert suppressor.rule.status(6.0)["in_control"] == "upper"


def test_namespace_moves_the_whole_robot():
    built, turns = run(1, namespace="/robot1")
    assert built.modules["turn"].node.name == "/robot1/turn"
    assert turns and all(z == pytest.approx(math.pi / 4) for t, z in turns if t >= 1.0)


def test_existing_nodes_cannot_run_in_process(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{EXAMPLE.parents[2]}:/usr/share")
    path = write(tmp_path, LEVEL0 + """\
      - name: echo
        node: rostopic/rostopic
        inputs: {heading: {from: runaway.heading, type: std_msgs/Float64}}
""")
    with pytest.raises(NetworkInvalid) as raised:
        build_local(load(path), LocalRuntime())
    [error] = raised.value.errors
    assert str(error).startswith(f"{path}:17: module echo: node rostopic/rostopic is an existing ROS node")
