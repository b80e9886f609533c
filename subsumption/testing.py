"""Test a module on hand-made inputs, without ROS and without wiring a network.

    harness = Harness(Runaway, params={"threshold": 0.5})
    harness.feed("force", force_msg)
    harness.run_for(0.1)
    assert harness.sent("heading")[-1].data == pytest.approx(math.pi)

The module runs in a :class:`~subsumption.local.LocalRuntime` of its own: inputs are fed on their own topics,
every output is recorded with the time it was sent, and time moves only when the test says so.
"""
from __future__ import annotations

from typing import Any, Mapping

from .local import LocalRuntime
from .module import Module
from .runtime import Message


class Harness:
    """A module alone in a LocalRuntime, its inputs fed by hand and its outputs recorded: a module tested on made-up
    messages, on a simulated clock."""
    def __init__(self, module_class: type[Module], params: Mapping[str, Any] | None = None,
                 name: str = "module_under_test") -> None:
        self.runtime = LocalRuntime()
        interface = module_class.interface
        remap = {port: f"/in/{port}" for port in interface.inputs}
        remap.update({f"~{port}": f"/out/{port}" for port in interface.outputs})
        self.module = self.runtime.add_module(module_class, name, remap=remap, params=params)
        feeder = self.runtime.node("harness_feeder")
        self._feeds = {port: feeder.publisher(f"/in/{port}", spec.msg_type)
                       for port, spec in interface.inputs.items()}
        self.outputs: dict[str, list[tuple[float, Message]]] = {port: [] for port in interface.outputs}
        recorder = self.runtime.node("harness_recorder")
        for port, spec in interface.outputs.items():
            recorder.subscribe(f"/out/{port}", spec.msg_type,
                               lambda msg, port=port: self.outputs[port].append((self.runtime.now(), msg)))

    def feed(self, port: str, msg: Message) -> None:
        """Send `msg` to input `port` now and let the module handle it."""
        self._feeds[port].publish(msg)
        self.runtime.run_for(0.0)

    def run_for(self, seconds: float) -> None:
        """Run the module's timers and deliveries for `seconds` of simulated time."""
        self.runtime.run_for(seconds)

    def sent(self, port: str) -> list[Message]:
        """Messages the module sent on output `port`, oldest first."""
        return [msg for _, msg in self.outputs[port]]
