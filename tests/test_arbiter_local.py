"""The in-process Arbiter between real modules on the LocalRuntime's simulated clock.

Times are multiples of 1/8 s so that every boundary (a lower message exactly T after an upper one) is exact
in floating point: the tests can then say precisely which message passes, which is the point of having a
deterministic runtime.
"""
from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import Empty, Float64, String

from subsumption.arbiter import STATUS_PERIOD, Arbiter
from subsumption.arbitration import ArbiterKind, ArbiterRule
from subsumption.local import LocalRuntime
from subsumption.module import Input, Module, Output, Param


class Talker(Module):
    """Publishes `schedule` (a list of (time, text)) on ~text at exactly those times."""

    text = Output(String)
    schedule = Param([], "list of (time, text)")

    def setup(self) -> None:
        for when, text in self.schedule:
            self.after(when - self.now(), lambda text=text: self.text.publish(String(text)))


class Listener(Module):
    """Records (time, data) of everything that arrives on `text`."""

    text = Input(String)

    def setup(self) -> None:
        self.heard: list[tuple[float, str]] = []

    def on_text(self, msg: String) -> None:
        self.heard.append((self.now(), msg.data))


class StatusListener(Module):
    status = Input(DiagnosticStatus)

    def setup(self) -> None:
        self.heard: list[tuple[float, DiagnosticStatus]] = []

    def on_status(self, msg: DiagnosticStatus) -> None:
        self.heard.append((self.now(), msg))


def wire(kind: str, T: float, upper: list[tuple[float, str]], lower: list[tuple[float, str]], end: float = 6.0):
    """upper talker + lower talker -> arbiter /arb -> listener, plus a listener on /arb/status; runs to `end`."""
    runtime = LocalRuntime()
    runtime.add_module(Talker, "avoid", params={"schedule": upper})
    runtime.add_module(Talker, "runaway", params={"schedule": lower})
    arbiter = Arbiter(runtime.node("arb", remap={"upper": "/avoid/text", "lower": "/runaway/text",
                                                 "output": "/turn/text"}), kind, T, String)
    out = runtime.add_module(Listener, "motor", remap={"text": "/turn/text"})
    status = runtime.add_module(StatusListener, "monitor", remap={"status": "/arb/status"})
    runtime.run_until(end)
    return arbiter, out.heard, status.heard


def ticks(start: float, stop: float, step: float, tag: str) -> list[tuple[float, str]]:
    n = int(round((stop - start) / step))
    return [(start + i * step, f"{tag}{start + i * step:g}") for i in range(n + 1)]


LOWER = ticks(0.0, 4.0, 0.125, "L")      # lower line: every 1/8 s
UPPER = [(1.0, "U1"), (1.25, "U1.25")]   # upper line: a short burst


def test_suppressor_forwards_upper_and_drops_lower_within_T():
    arbiter, heard, _ = wire("suppressor", 0.5, UPPER, LOWER)
    times = [t for t, _ in heard]
    assert times == sorted(times) and all(t == float(d[1:]) for t, d in heard)   # forwarded without delay
    lower_out = [t for t, d in heard if d.startswith("L")]
    assert [d for _, d in heard if d.startswith("U")] == ["U1", "U1.25"]
    # lower at 1.0 is published after U1 was scheduled, so it already falls in the window (0 < T)
    assert lower_out == [t for t, _ in LOWER if not (1.0 <= t < 1.75)]
    assert 1.625 not in lower_out and 1.75 in lower_out          # the exact boundary passes
    assert (arbiter.rule.upper.passed, arbiter.rule.lower.dropped) == (2, 6)


def test_inhibitor_drops_lower_within_T_and_never_forwards_upper():
    arbiter, heard, _ = wire("inhibitor", 0.5, UPPER, LOWER)
    assert all(d.startswith("L") for _, d in heard)
    assert [t for t, _ in heard] == [t for t, _ in LOWER if not (1.0 <= t < 1.75)]
    assert (arbiter.rule.upper.passed, arbiter.rule.upper.dropped) == (0, 2)


def test_inhibitor_upper_line_may_carry_another_type():
    runtime = LocalRuntime()
    Arbiter(runtime.node("arb"), "inhibitor", 1.0, String, upper_type=Empty)
    assert runtime.topics["/upper"].msg_type is Empty and runtime.topics["/lower"].msg_type is String


def test_defaulter_lower_wins_upper_after_silence():
    lower = [(0.5, "L0.5"), (1.0, "L1"), (3.0, "L3")]
    upper = ticks(0.0, 5.0, 0.25, "U")
    _, heard, _ = wire("defaulter", 1.0, upper, lower)
    assert [d for _, d in heard if d.startswith("L")] == ["L0.5", "L1", "L3"]
    upper_out = [t for t, d in heard if d.startswith("U")]
    # upper passes before any lower, and once lower has been silent for exactly T = 1 s. At a shared instant
    # (0.5, 1.0, 3.0) the upper talker publishes first (it was added first), so it sees the older lower time.
    assert upper_out == [t for t, _ in upper if t <= 0.5 or 2.0 <= t <= 3.0 or t >= 4.0]


def test_status_on_change_and_periodically():
    arbiter, _, status = wire("suppressor", 0.5, UPPER, LOWER, end=4.5)
    in_control = [(t, s.message) for t, s in status]
    # on change: upper takes over at 1.0; lower is back with the first lower message after the window (1.75)
    assert (1.0, "upper line in control") in in_control
    assert (1.75, "lower line in control") in in_control
    # ... and periodically, once a STATUS_PERIOD (at 1.0 both a periodic and an on-change message)
    assert [t for t, _ in status] == [1.0, 1.0, 1.75, 2.0, 3.0, 4.0]
    assert STATUS_PERIOD == 1.0
    last = status[-1][1]
    assert last.level == DiagnosticStatus.OK and last.name == "/arb"
    values = {kv.key: kv.value for kv in last.values}
    # the tick at 4.0 was queued (at 3.0) before the delivery of the lower message published at 4.0
    assert values == {"kind": "suppressor", "time_constant": "0.5", "in_control": "lower", "until": "",
                      "upper_passed": "2", "upper_dropped": "0",
                      "lower_passed": str(len(LOWER) - 6 - 1), "lower_dropped": "6",
                      "upper_queue_dropped": "0", "lower_queue_dropped": "0"}
    assert isinstance(arbiter.rule, ArbiterRule)     # the one shared timing rule


def test_status_reports_upper_between_messages():
    """A periodic status that falls inside a window says upper is in control."""
    _, _, status = wire("suppressor", 2.5, [(0.5, "U")], [], end=3.0)
    assert [(t, s.message) for t, s in status] == [
        (0.5, "upper line in control"), (1.0, "upper line in control"), (2.0, "upper line in control"),
        (3.0, "lower line in control")]


def test_mismatched_types_are_a_type_error_naming_topics_and_types():
    runtime = LocalRuntime()
    node = runtime.node("arb", remap={"upper": "/avoid/heading", "lower": "/runaway/heading"})
    with pytest.raises(TypeError) as error:
        Arbiter(node, ArbiterKind.SUPPRESSOR, 1.0, String, upper_type=Float64)
    text = str(error.value)
    for part in ("/avoid/heading", "/runaway/heading", "std_msgs/Float64", "std_msgs/String"):
        assert part in text
    assert text.index("/avoid/heading") < text.index("std_msgs/Float64") < text.index("/runaway/heading")


def test_defaulter_also_needs_one_type():
    with pytest.raises(TypeError, match="std_msgs/Empty"):
        Arbiter(LocalRuntime().node("arb"), "defaulter", 1.0, String, upper_type=Empty)


@pytest.mark.parametrize("bad", [0, -1.0, None, "1.0", True])
def test_bad_time_constant(bad):
    with pytest.raises(ValueError, match="time_constant"):
        Arbiter(LocalRuntime().node("arb"), "suppressor", bad, String)
