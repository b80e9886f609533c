"""Inhibitors, suppressors and defaulters as modules of the in-process runtime, and the status they report.

The ROS node (:mod:`subsumption.ros.arbiter_node`) relays serialized bytes of any type; this class relays
message objects between the same three topics. Both ask the same :class:`~subsumption.arbitration.ArbiterRule`,
so the two runtimes cannot disagree on timing, and both publish the same status message.
"""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from .arbitration import ArbiterKind, ArbiterRule
from .runtime import Message, MessageType, NodeHandle

STATUS_PERIOD = 1.0  # seconds between status messages when nothing changes
EXPIRY_CHECK_PERIOD = 0.1  # seconds between looks for a window that ran out with no message to report it


def status_message(node_name: str, rule: ArbiterRule, now: float, error: str = "",
                   dropping: str = "") -> DiagnosticStatus:
    """The arbiter's state as a standard diagnostic (readable with `rostopic echo` and rqt_robot_monitor): ERROR
    with `error`, WARN while `dropping` says what the input queue lost lately (as a module node goes WARN when
    it drops messages), else OK."""
    state = rule.status(now)
    in_control = f"{state['in_control']} line in control"
    return DiagnosticStatus(
        level=DiagnosticStatus.ERROR if error else DiagnosticStatus.WARN if dropping else DiagnosticStatus.OK,
        name=node_name,
        message=error or (f"{in_control}; {dropping}" if dropping else in_control),
        hardware_id="",
        values=[KeyValue(key, str(value)) for key, value in state.items()],
    )


class Arbiter:
    """An arbiter between `upper` and `lower`, publishing on `output` and `~status`, for one message type."""

    def __init__(self, node: NodeHandle, kind: ArbiterKind | str, time_constant: float,
                 msg_type: MessageType, upper_type: MessageType | None = None) -> None:
        self.node = node
        self.rule = ArbiterRule(ArbiterKind(kind), time_constant)
        upper_type = upper_type or msg_type
        if self.rule.kind.needs_same_type and upper_type is not msg_type:
            raise TypeError(
                f"{node.name}: a {self.rule.kind.value} forwards its upper line, so upper "
                f"{node.resolve('upper')} ({upper_type._type}) and lower {node.resolve('lower')} "
                f"({msg_type._type}) must have one type")
        self._output = node.publisher("output", msg_type)
        self._status = node.publisher("~status", DiagnosticStatus)
        self._upper_in_control = False
        node.subscribe("upper", upper_type, self._on_upper)
        node.subscribe("lower", msg_type, self._on_lower)
        node.call_every(STATUS_PERIOD, self.publish_status)
        node.call_every(EXPIRY_CHECK_PERIOD, self._status_on_change)

    def _on_upper(self, msg: Message) -> None:
        if self.rule.on_upper(self.node.now()):
            self._output.publish(msg)
        self._status_on_change()

    def _on_lower(self, msg: Message) -> None:
        if self.rule.on_lower(self.node.now()):
            self._output.publish(msg)
        self._status_on_change()

    def _status_on_change(self) -> None:
        if self.rule.upper_in_control(self.node.now()) != self._upper_in_control:
            self.publish_status()

    def publish_status(self) -> None:
        now = self.node.now()
        self._upper_in_control = self.rule.upper_in_control(now)
        self._status.publish(status_message(self.node.name, self.rule, now))
