"""The one wiring: what each level runs, direct lines without active arbiters, stacked arbiters, output lines."""
from __future__ import annotations

import pytest
from test_network_files import DEMO, EXAMPLE, LEVEL0, WANDER, write

from subsumption.network import End, NetworkInvalid, load, wire

ROOT = EXAMPLE.parent.parent.parent

THREE_LEVELS = LEVEL0 + WANDER + f"""\
      - {{kind: suppressor, upper: avoid.heading, lower: turn.heading, time_constant: 20}}
  - name: override
    modules:
      - name: override
        class: {DEMO}:Wander
      - name: steer
        class: {DEMO}:Turn
        inputs: {{heading: override.heading}}
    arbiters:
      - {{kind: suppressor, name: take_turn, upper: override.heading, lower: turn.heading, time_constant: 5}}
      - {{kind: inhibitor, upper: override.heading, lower: runaway.heading, time_constant: 3}}
      - {{kind: suppressor, upper: steer.cmd_vel, lower: turn.cmd_vel, time_constant: 1}}
"""


@pytest.fixture
def three(tmp_path):
    return load(write(tmp_path, THREE_LEVELS))


def test_level0_is_wired_directly(three):
    wiring = wire(three, 0)
    assert [m.name for m in wiring.modules] == ["feelforce", "runaway", "turn"]
    assert wiring.arbiters == []
    assert wiring.module("turn").remaps == {"heading": "runaway/heading", "~cmd_vel": "cmd_vel"}
    assert wiring.module("runaway").remaps == {"force": "feelforce/force"}
    assert wiring.module("feelforce").remaps == {}  # outputs publish ~force = feelforce/force by themselves


def test_level1_inserts_the_suppressor_at_turn(three):
    wiring = wire(three, 1)
    [suppressor] = wiring.arbiters
    assert (suppressor.name, suppressor.kind, suppressor.line) == ("suppressor_turn_heading", "suppressor", "input")
    assert (suppressor.upper, suppressor.lower, suppressor.output) == (
        "avoid/heading", "runaway/heading", "suppressor_turn_heading/output")
    assert suppressor.time_constant == pytest.approx(2.0)  # 20 units of 0.1 s
    assert wiring.module("turn").remaps["heading"] == "suppressor_turn_heading/output"
    assert wiring.module("avoid").remaps == {"heading": "wander/heading", "force": "feelforce/force"}


def test_level2_stacks_arbiters_and_splits_output_lines(three):
    wiring = wire(three, 2)
    by_name = {a.name: a for a in wiring.arbiters}
    assert list(by_name) == ["suppressor_turn_heading", "take_turn", "inhibitor_runaway_heading",
                             "suppressor_turn_cmd_vel"]
    # The inhibitor sits on runaway's output line, so the level-1 suppressor now reads its output ...
    inhibitor = by_name["inhibitor_runaway_heading"]
    assert inhibitor.line == "output"
    assert (inhibitor.upper, inhibitor.lower, inhibitor.output) == (
        "override/heading", "runaway/heading", "inhibitor_runaway_heading/output")
    assert inhibitor.time_constant == pytest.approx(0.3)
    first = by_name["suppressor_turn_heading"]
    assert first.lower == "inhibitor_runaway_heading/output"
    # ... and the level-2 suppressor on the same input line sits after it, nearer the reader.
    second = by_name["take_turn"]
    assert (second.lower, second.output) == ("suppressor_turn_heading/output", "take_turn/output")
    assert wiring.module("turn").remaps["heading"] == "take_turn/output"
    # An output line delivered outside reaches it after its arbiters: turn publishes its own topic again.
    on_cmd_vel = by_name["suppressor_turn_cmd_vel"]
    assert (on_cmd_vel.upper, on_cmd_vel.lower, on_cmd_vel.output) == ("steer/cmd_vel", "turn/cmd_vel", "cmd_vel")
    assert "~cmd_vel" not in wiring.module("turn").remaps
    assert wiring.topics()["cmd_vel"] == "geometry_msgs/Twist"


def test_wires_follow_the_arbiters(three):
    wiring = wire(three, 2)
    into_turn = [w for w in wiring.wires if w.target == End("module", "turn", "heading")]
    assert [(w.source, w.topic) for w in into_turn] == [(End("arbiter", "take_turn", "output"), "take_turn/output")]
    uppers = {w.target.name: w.source for w in wiring.wires if w.target.port == "upper"}
    assert uppers["suppressor_turn_heading"] == End("module", "avoid", "heading")
    assert [w.source for w in wiring.wires if w.target == End("external", "cmd_vel")] == [
        End("arbiter", "suppressor_turn_cmd_vel", "output")]


def test_existing_node_gets_remaps_for_inputs_and_outputs(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")
    network = load(write(tmp_path, LEVEL0.replace("  cmd_vel: geometry_msgs/Twist", "  cmd_vel: geometry_msgs/Twist\n"
                                                  "  echoed: std_msgs/Float64") + """\
      - name: echo
        node: rostopic/rostopic
        args: echo heading
        inputs: {heading: {from: runaway.heading, type: std_msgs/Float64}}
        outputs: {copy: {type: std_msgs/Float64, topic: out, to: echoed}}
        params: {rate: 2}
        remap: {extra: /elsewhere}
"""))
    echo = wire(network).module("echo")
    assert echo.remaps == {"heading": "runaway/heading", "out": "echoed", "extra": "/elsewhere"}
    assert echo.params == {"rate": 2}


def test_example_time_unit_and_levels():
    network = load(EXAMPLE)
    assert network.time_unit == 0.1 and [level.name for level in network.levels] == ["avoid objects", "wander"]
    assert [a.time_constant for a in wire(network).arbiters] == [pytest.approx(2.0)]


def test_wire_refuses_a_broken_network(tmp_path):
    network = load(write(tmp_path, LEVEL0.replace("{heading: runaway.heading}", "{heading: runaway.nothing}")))
    with pytest.raises(NetworkInvalid, match="module runaway has no output 'nothing'"):
        wire(network)
