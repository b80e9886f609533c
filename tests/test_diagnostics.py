"""An AFSM publishes its state and registers on ~afsm whenever they change (both runtimes share this code; here on
the in-process runtime, exactly), and message summaries stay short whatever the message."""
from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Empty, Float64

from subsumption import AFSM, EventDispatch, Input, LocalRuntime, MachineError, Output, OutputState
from subsumption.brief import brief
from subsumption.examples.avoid import Avoid


def test_afsm_reports_state_and_registers_on_every_change():
    runtime = LocalRuntime()
    runtime.add_module(Avoid, "avoid", remap={"heading": "/h", "force": "/f"})
    reports: list[tuple[float, DiagnosticStatus]] = []
    runtime.node("watcher").subscribe("/avoid/afsm", DiagnosticStatus, lambda m: reports.append((runtime.now(), m)))
    source = runtime.node("src")
    runtime.run_until(0.5)
    force = Vector3Stamped()
    force.vector.y = -1.0
    source.publisher("/f", Vector3Stamped).publish(force)
    runtime.run_until(1.0)
    source.publisher("/h", Float64).publish(Float64(0.25))
    runtime.run_until(2.0)
    assert [when for when, _ in reports] == [0.0, 0.5, 1.0]  # the start, then one per input; none while idle
    values = [{kv.key: kv.value for kv in status.values} for _, status in reports]
    assert [v["state"] for v in values] == ["nil", "nil", "nil"]
    assert [v["transitions"] for v in values] == ["0", "0", "4"]  # the heading ran plan, go, start, back to nil
    assert values[0]["register force"] == "none" and values[0]["register heading"] == "none"
    assert values[1]["register force"] == "{header: {stamp: 0.000, frame: -}, vector: {x: 0, y: -1, z: 0}}"
    assert values[2]["register heading"] == "0.25"
    assert reports[-1][1].name == "/avoid" and reports[-1][1].message == "state nil"


def test_a_late_subscriber_gets_the_latest_state():
    runtime = LocalRuntime()
    runtime.add_module(Avoid, "avoid")
    runtime.run_until(1.0)
    late: list[DiagnosticStatus] = []
    runtime.node("late").subscribe("/avoid/afsm", DiagnosticStatus, late.append)
    runtime.run_for(0.0)
    assert [status.message for status in late] == ["state nil"]


def test_an_output_may_not_take_the_machine_state_topic():
    with pytest.raises(MachineError, match="an output may not be called 'afsm'"):
        class Clash(AFSM):
            go = Input(Empty)
            afsm = Output(Empty)
            states = [EventDispatch("wait", on={"go": "send"}), OutputState("send", "afsm", "make", next="wait")]

            def make(self) -> Empty:
                return Empty()


def test_brief_keeps_big_messages_short():
    scan = LaserScan()
    scan.header.frame_id = "laser"
    scan.ranges = [1.0] * 541
    text = brief(scan)
    assert text.startswith("{header: {stamp: 0.000, frame: laser}, angle_min: 0, ") and text.endswith("…")
    assert len(text) == 160
    assert brief(scan.ranges) == "[541 items]"
    assert brief(Float64(1 / 3)) == "0.3333" and brief([1.0, 2.0]) == "[1, 2]"
