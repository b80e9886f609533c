"""The simulator node's pacing (subsim.ros_node.run): simulated time at `rate` x wall time, and a machine too slow
for the rate is said, not hidden: the times it fell behind and the wall time it never made up. The wall clock is a
fake one here (each step costs what the test says), so nothing depends on how busy the machine running it is."""
from types import SimpleNamespace

import pytest

import subsim.ros_node
from subsim.ros_node import BEHIND_S, run


class FakeWall:
    """time.monotonic and time.sleep for run(): sleeping moves the clock on, and so does a step's cost."""

    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


class Stepper:
    """A simulation stepped by run(): each step advances `dt` simulated s and costs `cost(step)` wall s."""

    def __init__(self, wall: FakeWall, dt: float, cost) -> None:
        self.sim = SimpleNamespace(time=0.0)
        self.wall, self.dt, self.cost, self.steps = wall, dt, cost, 0

    def step(self) -> None:
        self.wall.now += self.cost(self.steps)
        self.steps += 1
        self.sim.time += self.dt


@pytest.fixture
def wall(monkeypatch):
    clock = FakeWall()
    monkeypatch.setattr(subsim.ros_node, "time", clock)
    return clock


def test_a_machine_fast_enough_keeps_the_rate_and_never_falls_behind(wall):
    paced = run(Stepper(wall, 0.02, lambda step: 0.001), rate=4.0, duration=1.0)
    assert paced.simulated == pytest.approx(1.0)
    assert paced.wall == pytest.approx(0.25, abs=0.005)
    assert (paced.falls, paced.lost) == (0, 0.0)


def test_stalls_longer_than_the_slack_are_counted_and_not_rushed_back(wall):
    """Two steps stall 0.6 wall s each: the simulation falls behind twice, by about that each time, and carries on
    from there; the run takes that much longer than the rate asks. A stall of 0.2 s (within the slack) between them
    is made up by the steps after it."""
    assert 0.2 < BEHIND_S < 0.6
    stalls = {10: 0.6, 20: 0.2, 150: 0.6}
    paced = run(Stepper(wall, 0.02, lambda step: stalls.get(step, 0.001)), rate=4.0, duration=4.0)
    assert paced.falls == 2
    assert paced.lost == pytest.approx(2 * (0.6 - 0.005), abs=0.01)
    assert paced.wall == pytest.approx(1.0 + paced.lost, abs=0.01)
