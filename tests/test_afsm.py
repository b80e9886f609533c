"""Brooks' AFSMs and plain-callback modules on the in-process runtime, with the paper's avoid as the example."""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Vector3Stamped
from std_msgs.msg import Float64, String

from subsumption import (AFSM, ConditionalDispatch, EventDispatch, Input, LocalRuntime, MachineError, Module,
                         Output, OutputState, Param, SideEffect, TopicTypeError)
from subsumption.examples.avoid import Avoid, AvoidCallbacks
from subsumption.testing import Harness


def force(x: float, y: float) -> Vector3Stamped:
    msg = Vector3Stamped()
    msg.vector.x, msg.vector.y = x, y
    return msg


def run_avoid(module_class, events):
    """Feed (time, input, msg) events to an avoid module; return (time, heading) of what it sends."""
    harness = Harness(module_class)
    for when, port, msg in events:
        harness.runtime.run_until(when)
        harness.feed(port, msg)
    harness.run_for(1.0)
    return [(when, msg.data) for when, msg in harness.outputs["heading"]]


@pytest.mark.parametrize("module_class", [Avoid, AvoidCallbacks])
def test_avoid_waits_for_a_heading_and_bends_it_away_from_the_force(module_class):
    sent = run_avoid(module_class, [
        (0.5, "force", force(0.0, -1.0)),          # a wall on the left pushes to the right
        (1.0, "force", force(0.0, -1.0)),
        (2.0, "heading", Float64(0.0)),     # wander wants straight ahead
    ])
    assert len(sent) == 1, "the force alone must not produce a heading; the heading message does"
    when, heading = sent[0]
    assert when == pytest.approx(2.0)
    assert heading == pytest.approx(-math.pi / 4)  # (1,0) + (0,-1): 45 degrees to the right


@pytest.mark.parametrize("module_class", [Avoid, AvoidCallbacks])
def test_avoid_stays_silent_when_the_force_cancels_the_wanted_direction(module_class):
    sent = run_avoid(module_class, [(0.1, "force", force(-1.0, 0.0)), (0.2, "heading", Float64(0.0))])
    assert sent == []


def test_avoid_machine_moves_through_the_four_kinds_of_state():
    runtime = LocalRuntime()
    avoid = runtime.add_module(Avoid, "avoid", remap={"heading": "/h"})
    runtime.run_for(0.1)
    assert avoid.state.name == "nil"
    runtime.node("src").publisher("/h", Float64).publish(Float64(0.3))
    runtime.run_for(0.1)
    assert avoid.state.name == "nil" and avoid.transitions == 4  # plan, go, start, nil
    assert [s.kind for s in Avoid.states] == ["event dispatch", "side effect", "conditional dispatch", "output"]


def test_machine_can_be_printed_and_drawn():
    text = Avoid.describe_machine()
    assert "nil" in text and "[conditional dispatch]" in text and "heading? -> plan" in text
    dot = Avoid.to_dot()
    assert '"go" [shape=diamond' in dot and '"nil" -> "plan" [label="heading?"]' in dot


class Blinker(AFSM):
    """Sends 'on' then waits 1 s (monostable) or for a 'stop' message; reset restarts it."""

    stop = Input(String)
    light = Output(String)
    states = [
        OutputState("on", "light", "on_message", next="wait"),
        EventDispatch("wait", on={"stop": "halted"}, timeout=1.0, on_timeout="on"),
        EventDispatch("halted"),
    ]

    def on_message(self) -> String:
        return String("on")


def test_event_dispatch_timeout_repeats_until_an_input_arrives_and_reset_restarts():
    runtime = LocalRuntime()
    blinker = runtime.add_module(Blinker, "blinker", remap={"stop": "/stop"})
    times = []
    runtime.node("probe").subscribe("/blinker/light", String, lambda m: times.append(runtime.now()))
    runtime.run_until(2.5)
    assert times == pytest.approx([0.0, 1.0, 2.0])
    runtime.node("stopper").publisher("/stop", String).publish(String("stop"))
    runtime.run_until(5.0)
    assert blinker.state.name == "halted" and len(times) == 3
    blinker.reset()
    runtime.run_until(5.0)  # deliveries happen on the runtime's queue, at the same time
    assert times[-1] == pytest.approx(5.0) and blinker.state.name == "wait"


def test_bad_machines_are_refused_with_the_class_and_state_named():
    with pytest.raises(MachineError, match=r"Broken, state 'a': goes to unknown state 'b'"):
        class Broken(AFSM):
            out = Output(String)
            states = [SideEffect("a", "work", next="b")]

            def work(self):
                pass
    with pytest.raises(MachineError, match=r"Loop.*no method 'missing'"):
        class Loop(AFSM):
            states = [ConditionalDispatch("a", "missing", then="a", otherwise="a")]


def test_a_machine_that_never_waits_is_reported():
    class Spin(AFSM):
        states = [SideEffect("a", "work", next="a")]

        def work(self):
            pass

    runtime = LocalRuntime()
    runtime.add_module(Spin, "spin")
    with pytest.raises(MachineError, match="without waiting"):
        runtime.run_for(0.1)


class Counter(Module):
    """Plain callbacks sharing registers, with a parameter and a periodic timer."""

    tick = Input(String)
    count = Output(String)
    every_s = Param(0.5)

    def setup(self):
        self.ticks = 0
        self.every(self.every_s, self.report)

    def on_tick(self, msg):
        self.ticks += 1

    def report(self):
        self.count.publish(String(f"{self.ticks} last={self.registers.tick.data if self.registers.tick else None}"))


def test_module_registers_parameters_timers_and_remaps():
    runtime = LocalRuntime()
    runtime.add_module(Counter, "counter", remap={"tick": "/ticks", "~count": "/report"}, params={"every_s": 1.0})
    got = []
    runtime.node("probe").subscribe("/report", String, lambda m: got.append((runtime.now(), m.data)))
    source = runtime.node("src").publisher("/ticks", String)
    runtime.run_until(0.2)
    source.publish(String("a"))
    source.publish(String("b"))
    runtime.run_until(2.0)
    assert got == [(1.0, "2 last=b"), (2.0, "2 last=b")]
    assert "param  every_s = 0.5" in Counter.describe()


def test_topic_type_conflicts_name_the_topic_and_both_types():
    runtime = LocalRuntime()
    runtime.node("a").publisher("/line", String)
    with pytest.raises(TopicTypeError, match=r"/line: subscriber /b uses std_msgs/Float64 but publisher /a uses "
                                             r"std_msgs/String"):
        runtime.node("b").subscribe("/line", Float64, lambda m: None)
