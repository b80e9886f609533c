"""The patrol robot's alarm: one place that keeps which alarms are raised, so any level can raise one.

An alarm is a ``diagnostic_msgs/DiagnosticStatus``, the type ROS drivers use for "something is wrong":

- ``name``: what (``intruder``, ``bumper``, ``navigation``); one alarm per name.
- ``level``: ``WARN`` or ``ERROR`` raises it, ``OK`` clears it.
- ``message``: the sentence the sound module says (``"Intruder at x 3.2, y 1.5"``).
- ``values``: where, as key-values ``x``, ``y`` and ``frame`` (any others are kept).

Any module publishes such a status on the alarm's ``trigger`` input. The alarm module answers with the list of
raised alarms on ``alarms`` (a latched ``DiagnosticArray`` whose header stamp is when the list last changed,
so ``rostopic echo`` and rqt's robot monitor show it) and with an ``announce`` for each alarm newly raised or
cleared, which is what the sound module speaks. Repeated triggers of a raised alarm only refresh it: it is
announced again only after ``repeat`` seconds, so a detector firing at 30 Hz never queues up 30 sounds a
second. An alarm that nobody triggers for ``hold`` seconds clears itself.
"""
from __future__ import annotations

from dataclasses import dataclass

import genpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from subsumption import Input, Module, Output, Param

RAISED = (DiagnosticStatus.WARN, DiagnosticStatus.ERROR)


def alarm_status(what: str, message: str, x: float | None = None, y: float | None = None, frame: str = "map",
                 level: int = DiagnosticStatus.WARN) -> DiagnosticStatus:
    """A trigger for the alarm module: raise `what` (or clear it with level OK), said as `message`, at (x, y)."""
    values = [] if x is None or y is None else [KeyValue("x", f"{x:.2f}"), KeyValue("y", f"{y:.2f}"),
                                                KeyValue("frame", frame)]
    return DiagnosticStatus(level=level, name=what, message=message, values=values)


@dataclass
class _Raised:
    status: DiagnosticStatus
    raised_at: float
    last_trigger: float
    announced_at: float


class Alarm(Module):
    """Raises and clears the robot's alarms (what, where, when) on behalf of every level; announces each new one
    once, and again every `repeat` seconds while it stays raised."""

    trigger = Input(DiagnosticStatus, "raise (level WARN or ERROR) or clear (level OK) the alarm called name")
    alarms = Output(DiagnosticArray, "the alarms raised now (latched; stamp: when the list changed)", latch=True)
    announce = Output(DiagnosticStatus, "an alarm newly raised (or cleared): what to say")
    hold = Param(30.0, "s an alarm stays raised with no new trigger before it clears itself (0: until cleared)")
    repeat = Param(20.0, "s before a still-raised, still-triggered alarm is announced again")
    announce_clear = Param(False, "also announce when an alarm clears")

    def setup(self) -> None:
        self.raised: dict[str, _Raised] = {}
        self.count = 0  # alarms raised since start (a raise after a clear counts again)
        self._publish_list()
        if self.hold > 0:
            self.every(min(1.0, self.hold / 2), self._expire)

    def on_trigger(self, status: DiagnosticStatus) -> None:
        now = self.now()
        name = status.name or "alarm"
        current = self.raised.get(name)
        if status.level in RAISED:
            stamped = DiagnosticStatus(level=status.level, name=name, message=status.message,
                                       hardware_id=status.hardware_id,
                                       values=list(status.values) + [KeyValue("raised_at", f"{now:.3f}")])
            if current is None:
                self.count += 1
                self.raised[name] = _Raised(stamped, now, now, now)
                self.log(f"alarm raised: {name}: {status.message}", "warn")
                self.announce.publish(stamped)
                self._publish_list()
            else:
                stamped.values[-1] = KeyValue("raised_at", f"{current.raised_at:.3f}")
                current.status, current.last_trigger = stamped, now
                if now - current.announced_at >= self.repeat:
                    current.announced_at = now
                    self.announce.publish(stamped)
        elif current is not None:
            self._clear(name, status.message or f"{name} cleared")

    def _clear(self, name: str, message: str) -> None:
        del self.raised[name]
        self.log(f"alarm cleared: {name}: {message}")
        if self.announce_clear:
            self.announce.publish(DiagnosticStatus(level=DiagnosticStatus.OK, name=name, message=message))
        self._publish_list()

    def _expire(self) -> None:
        now = self.now()
        for name, alarm in list(self.raised.items()):
            if now - alarm.last_trigger >= self.hold:
                self._clear(name, f"{name}: no new trigger for {self.hold:.0f} s")

    def _publish_list(self) -> None:
        header = Header(stamp=genpy.Time.from_sec(self.now()))
        self.alarms.publish(DiagnosticArray(header=header, status=[a.status for a in self.raised.values()]))
