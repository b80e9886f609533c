"""ArbiterRule against an independent reference model.

The rule keeps two timestamps and compares one difference; the model below instead keeps *every* message
of the current epoch and scans them, in exact rational arithmetic, for any that still holds the output. The
two share no code and are written in different styles, so an off-by-one at the boundary (``<`` versus ``<=``),
a forgotten reset after time went backwards or a miscount shows up as a disagreement that hypothesis shrinks
to a few messages.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from subsumption.arbitration import ArbiterKind, ArbiterRule

KINDS = list(ArbiterKind)
GRID = Fraction(1, 64)  # dyadic: differences of grid times are exact in binary floating point


@dataclass
class ReferenceArbiter:
    """The spec, read literally.

    The *controlling* line is upper for inhibitors and suppressors, lower for defaulters: its messages open
    windows of length T. A message on the other line is "held off" iff some controlling message c of the
    current epoch has 0 <= t - c < T. An epoch ends when a message arrives earlier than a controlling
    message already seen (time went backwards): the old windows are forgotten.
    """

    kind: ArbiterKind
    T: Fraction
    epoch: list[Fraction] = field(default_factory=list)  # times of controlling messages this epoch
    counts: dict[str, list[int]] = field(default_factory=lambda: {"upper": [0, 0], "lower": [0, 0]})

    @property
    def controlling(self) -> str:
        return "lower" if self.kind is ArbiterKind.DEFAULTER else "upper"

    def held_off(self, t: Fraction) -> bool:
        return any(0 <= t - c < self.T for c in self.epoch)

    def message(self, line: str, t: Fraction) -> bool:
        if any(c > t for c in self.epoch):
            self.epoch = []
        if line == self.controlling:
            self.epoch.append(t)
            forward = line == "lower" or self.kind is ArbiterKind.SUPPRESSOR
        else:
            forward = not self.held_off(t)
        self.counts[line][0 if forward else 1] += 1
        return forward

    def upper_in_control(self, t: Fraction) -> bool:
        held = self.held_off(t)
        return not held if self.kind is ArbiterKind.DEFAULTER else held


def run_both(kind: ArbiterKind, T: Fraction, events: list[tuple[str, Fraction]]) -> tuple[ArbiterRule, ReferenceArbiter]:
    rule = ArbiterRule(kind, float(T))
    model = ReferenceArbiter(kind, T)
    for i, (line, t) in enumerate(events):
        expected = model.message(line, t)
        got = rule.on_upper(float(t)) if line == "upper" else rule.on_lower(float(t))
        assert got == expected, f"event {i}: {line} at {t} (T={T}, {kind.value}): rule {got}, model {expected}"
        assert rule.upper_in_control(float(t)) == model.upper_in_control(t), f"in control after event {i}"
    assert (rule.upper.passed, rule.upper.dropped) == tuple(model.counts["upper"])
    assert (rule.lower.passed, rule.lower.dropped) == tuple(model.counts["lower"])
    return rule, model


def timeline(steps: list[tuple[str, int]], start: int = 0) -> list[tuple[str, Fraction]]:
    """Turn (line, step in grid units) pairs into absolute times; negative steps are backwards jumps."""
    events, now = [], Fraction(start) * GRID
    for line, step in steps:
        now = max(Fraction(0), now + step * GRID)
        events.append((line, now))
    return events


lines = st.sampled_from(["upper", "lower"])
forward_steps = st.lists(st.tuples(lines, st.integers(0, 80) | st.just(0)), max_size=60)
any_steps = st.lists(st.tuples(lines, st.integers(0, 80) | st.integers(-400, -1)), max_size=60)
time_constants = st.integers(1, 200).map(lambda k: k * GRID)


@settings(max_examples=400, deadline=None)
@given(kind=st.sampled_from(KINDS), T=time_constants, steps=forward_steps, start=st.integers(0, 10**6))
def test_matches_reference_with_monotonic_time(kind, T, steps, start):
    run_both(kind, T, timeline(steps, start))


@settings(max_examples=400, deadline=None)
@given(kind=st.sampled_from(KINDS), T=time_constants, steps=any_steps)
def test_matches_reference_when_time_jumps_backwards(kind, T, steps):
    run_both(kind, T, timeline(steps))


@settings(max_examples=200, deadline=None)
@given(kind=st.sampled_from(KINDS), T=time_constants, steps=forward_steps, probes=st.lists(st.integers(-300, 300), max_size=8))
def test_upper_in_control_between_messages(kind, T, steps, probes):
    """Status is asked between messages too (the periodic ~status), also at times before the last message."""
    rule, model = run_both(kind, T, timeline(steps))
    last = timeline(steps)[-1][1] if steps else Fraction(0)
    for probe in probes:
        t = max(Fraction(0), last + probe * GRID)
        went_back = any(c > t for c in model.epoch)  # earlier than a window's start: that window is void
        expected = (kind is ArbiterKind.DEFAULTER) if went_back else model.upper_in_control(t)
        assert rule.upper_in_control(float(t)) == expected, f"probe at {t}, last message at {last}"


@settings(max_examples=200, deadline=None)
@given(kind=st.sampled_from(KINDS),
       T=st.floats(1e-6, 1e3, allow_nan=False, allow_infinity=False),
       times=st.lists(st.tuples(lines, st.floats(0, 1e4, allow_nan=False)), max_size=40))
def test_arbitrary_float_times(kind, T, times):
    """Off the grid, in float arithmetic: the rule's ``now - last < T`` decides, with no exact ties assumed."""
    events = sorted(times, key=lambda e: e[1])
    rule = ArbiterRule(kind, T)
    last: float | None = None
    for line, t in events:
        if line == ("lower" if kind is ArbiterKind.DEFAULTER else "upper"):
            expected = kind is not ArbiterKind.INHIBITOR
            got = rule.on_upper(t) if line == "upper" else rule.on_lower(t)
            last = t
        else:
            expected = last is None or not t - last < T
            got = rule.on_upper(t) if line == "upper" else rule.on_lower(t)
        assert got == expected


# Hand-written cases: the exact boundary, the spec's sentences one by one --------------------------------------

@pytest.mark.parametrize("kind", [ArbiterKind.INHIBITOR, ArbiterKind.SUPPRESSOR])
def test_window_boundary_is_half_open(kind):
    rule = ArbiterRule(kind, 0.5)
    assert rule.on_upper(10.0) is (kind is ArbiterKind.SUPPRESSOR)
    assert rule.on_lower(10.0) is False          # same instant: t - u = 0 < T
    assert rule.on_lower(10.499999) is False     # just inside
    assert rule.upper_in_control(10.499999)
    assert rule.on_lower(10.5) is True           # exactly T after: passes
    assert not rule.upper_in_control(10.5)
    assert (rule.lower.passed, rule.lower.dropped) == (1, 2)


def test_window_restarts_at_each_upper_message():
    rule = ArbiterRule("suppressor", 1.0)
    for t in (0.0, 0.75, 1.5, 2.25):
        assert rule.on_upper(t)
    assert not rule.on_lower(3.0)   # 0.75 after the last upper
    assert rule.on_lower(3.25)
    assert (rule.upper.passed, rule.upper.dropped, rule.lower.passed, rule.lower.dropped) == (4, 0, 1, 1)


def test_inhibitor_never_forwards_upper():
    rule = ArbiterRule(ArbiterKind.INHIBITOR, 1.0)
    assert [rule.on_upper(t) for t in (0.0, 5.0, 50.0)] == [False, False, False]
    assert (rule.upper.passed, rule.upper.dropped) == (0, 3)


def test_defaulter_lower_wins_and_upper_waits_for_silence():
    rule = ArbiterRule(ArbiterKind.DEFAULTER, 2.0)
    assert rule.on_upper(0.0)                    # lower never heard: upper is the default
    assert rule.upper_in_control(0.0)
    assert rule.on_lower(1.0)                    # lower always wins
    assert not rule.upper_in_control(1.0)
    assert not rule.on_upper(2.0)
    assert not rule.on_upper(2.999)
    assert rule.on_upper(3.0)                    # lower silent for exactly T
    assert rule.on_lower(3.5)
    assert (rule.upper.passed, rule.upper.dropped, rule.lower.passed, rule.lower.dropped) == (2, 2, 2, 0)


@pytest.mark.parametrize("kind", [ArbiterKind.INHIBITOR, ArbiterKind.SUPPRESSOR])
def test_backwards_time_resets_instead_of_blocking(kind):
    rule = ArbiterRule(kind, 5.0)
    rule.on_upper(1000.0)
    assert not rule.on_lower(1001.0)
    assert rule.on_lower(3.0)                    # simulation restarted: not blocked until t = 1005
    assert not rule.upper_in_control(3.0)
    rule.on_upper(4.0)
    assert not rule.on_lower(8.0) and rule.on_lower(9.0)


def test_defaulter_backwards_time_gives_upper_back():
    rule = ArbiterRule(ArbiterKind.DEFAULTER, 5.0)
    rule.on_lower(1000.0)
    assert not rule.on_upper(1001.0)
    assert rule.on_upper(2.0)


def test_status_summary():
    rule = ArbiterRule("suppressor", 0.25)
    rule.on_upper(1.0), rule.on_lower(1.1), rule.on_lower(1.3)
    assert rule.status(1.2) == {"kind": "suppressor", "time_constant": 0.25, "in_control": "upper",
                                "until": repr(1.0 + 0.25),
                                "upper_passed": 1, "upper_dropped": 0, "lower_passed": 1, "lower_dropped": 1,
                                "upper_queue_dropped": 0, "lower_queue_dropped": 0}
    assert rule.status(1.25)["in_control"] == "lower" and rule.status(1.25)["until"] == ""


@pytest.mark.parametrize("bad", [0, 0.0, -1, -0.5, None, True, False, "2.0", float("nan"), [1.0]])
@pytest.mark.parametrize("kind", KINDS)
def test_bad_time_constant_is_a_value_error(kind, bad):
    with pytest.raises(ValueError, match="time_constant"):
        ArbiterRule(kind, bad)


def test_unknown_kind_is_rejected():
    with pytest.raises(ValueError):
        ArbiterRule("multiplexer", 1.0)


def test_letters():
    assert [k.letter for k in KINDS] == ["I", "S", "D"]
    assert not ArbiterKind.INHIBITOR.needs_same_type and ArbiterKind.SUPPRESSOR.needs_same_type
