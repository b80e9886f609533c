"""Brooks' augmented finite state machines (AFSMs), on the module's registers.

An AFSM is a module whose behaviour is a list of states of four kinds (Brooks 1986; the paper's Fig. 2(a)):

- :class:`OutputState`          publish a message on an output, then go on;
- :class:`SideEffect`           compute something and keep it in an instance variable, then go on;
- :class:`ConditionalDispatch`  test a predicate, go to one state or another;
- :class:`EventDispatch`        wait: for a message on one of the inputs, or for a timer to run out.

Inputs write *registers* (the latest message on each input wins; ``self.registers.<input>``). The machine runs
from state to state until it reaches an :class:`EventDispatch` state, and waits there; an input that the state listens
for, or the expiry of its monostable timer, moves it on. ``reset()`` sends it back to its first state, as
Brooks' reset line does. Actions and predicates are methods of the module named by string, so a machine reads
like the diagram and can be drawn from the same declaration (:meth:`AFSM.to_dot`)::

    class Avoid(AFSM):
        states = [
            EventDispatch("nil", on={"heading": "plan"}),
            SideEffect("plan", "plan", next="go"),
            ConditionalDispatch("go", "clear_direction", then="start", otherwise="nil"),
            OutputState("start", "heading", "result_message", next="nil"),
        ]
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from .brief import brief
from .module import Module
from .runtime import Message, TimerHandle

MAX_STEPS = 1000  # transitions without waiting before the machine is declared stuck in a loop
STATE_TOPIC = "~afsm"  # latched diagnostic_msgs/DiagnosticStatus: the state and the registers, on change


@dataclass(frozen=True)
class State:
    name: str

    kind: ClassVar[str] = "state"

    def targets(self) -> dict[str, str]:
        """Label -> next state, for checking and drawing."""
        return {}


@dataclass(frozen=True)
class OutputState(State):
    """Publish ``self.<message>()`` on the output port named ``output``, then go to ``next``."""

    output: str
    message: str
    next: str
    kind: ClassVar[str] = "output"

    def targets(self) -> dict[str, str]:
        return {f"{self.output}!": self.next}


@dataclass(frozen=True)
class SideEffect(State):
    """Call ``self.<action>()`` (which sets instance variables), then go to ``next``."""

    action: str
    next: str
    kind: ClassVar[str] = "side effect"

    def targets(self) -> dict[str, str]:
        return {self.action: self.next}


@dataclass(frozen=True)
class ConditionalDispatch(State):
    """Go to ``then`` if ``self.<predicate>()`` is true, otherwise to ``otherwise``."""

    predicate: str
    then: str
    otherwise: str
    kind: ClassVar[str] = "conditional dispatch"

    def targets(self) -> dict[str, str]:
        return {self.predicate: self.then, f"not {self.predicate}": self.otherwise}


@dataclass(frozen=True)
class EventDispatch(State):
    """Wait for a message on one of the inputs in ``on`` (input -> next state), or, with ``timeout``
    (the monostable: seconds, or the name of a parameter holding them), for that much time without one
    (then go to ``on_timeout``)."""

    on: dict[str, str] = field(default_factory=dict)
    timeout: float | str | None = None
    on_timeout: str | None = None
    kind: ClassVar[str] = "event dispatch"

    def targets(self) -> dict[str, str]:
        found = {f"{name}?": target for name, target in self.on.items()}
        if self.timeout is not None and self.on_timeout:
            label = self.timeout if isinstance(self.timeout, str) else f"{self.timeout:g} s"
            found[label] = self.on_timeout
        return found


class MachineError(ValueError):
    """An AFSM declaration that cannot run: the message names the class and the state."""


class AFSM(Module):
    """A module whose behaviour is Brooks' augmented finite state machine. Subclasses set ``states``."""

    states: ClassVar[list[State]] = []
    _by_name: ClassVar[dict[str, State]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.states:
            cls._by_name = {state.name: state for state in cls.states}
            cls.validate()

    @classmethod
    def validate(cls) -> None:
        """Every target state exists, every named method exists, every event names an input or output."""
        where = f"{cls.__qualname__}"
        if len(cls._by_name) != len(cls.states):
            raise MachineError(f"{where}: two states share a name")
        if STATE_TOPIC[1:] in cls.interface.outputs:
            raise MachineError(f"{where}: an output may not be called {STATE_TOPIC[1:]!r}: the machine publishes "
                               f"its state on {STATE_TOPIC}")
        for state in cls.states:
            for label, target in state.targets().items():
                if target not in cls._by_name:
                    raise MachineError(f"{where}, state {state.name!r}: goes to unknown state {target!r}")
            methods = [getattr(state, attr) for attr in ("action", "predicate", "message") if hasattr(state, attr)]
            for method in methods:
                if not callable(getattr(cls, method, None)):
                    raise MachineError(f"{where}, state {state.name!r}: no method {method!r}")
            if isinstance(state, OutputState) and state.output not in cls.interface.outputs:
                raise MachineError(f"{where}, state {state.name!r}: no output {state.output!r}")
            if isinstance(state, EventDispatch):
                for name in state.on:
                    if name not in cls.interface.inputs:
                        raise MachineError(f"{where}, state {state.name!r}: waits for unknown input {name!r}")
                if (state.timeout is None) != (state.on_timeout is None):
                    raise MachineError(f"{where}, state {state.name!r}: timeout and on_timeout go together")
                if isinstance(state.timeout, str) and state.timeout not in cls.interface.params:
                    raise MachineError(f"{where}, state {state.name!r}: timeout names no parameter "
                                       f"{state.timeout!r}")

    # Running --------------------------------------------------------------------------------------
    def __init__(self, node) -> None:
        if not self.states:
            raise MachineError(f"{type(self).__qualname__}: an AFSM needs at least one state")
        self.state: State = self.states[0]
        self._timer: TimerHandle | None = None
        self.transitions = 0
        self._state_publisher = node.publisher(STATE_TOPIC, DiagnosticStatus, latch=True)
        super().__init__(node)
        self.after(0.0, self._start)  # start once the runtime runs, so subscribers can be connected

    def _start(self) -> None:
        self._run()
        self.report()

    def reset(self) -> None:
        """Back to the first state (Brooks' reset line); registers keep their contents."""
        self._enter(self.states[0])

    def on_input(self, name: str, msg: Message) -> None:
        state = self.state
        if isinstance(state, EventDispatch) and name in state.on:
            self._enter(self._by_name[state.on[name]])
        self.report()  # a register changed, and perhaps the state

    def _enter(self, state: State) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self.state = state
        self.transitions += 1
        self._run()

    def _run(self) -> None:
        """Step through non-waiting states until one waits (an EventDispatch state)."""
        for _ in range(MAX_STEPS):
            state = self.state
            if isinstance(state, EventDispatch):
                if state.timeout is not None and self._timer is None:
                    target = self._by_name[state.on_timeout]  # type: ignore[index]
                    duration = getattr(self, state.timeout) if isinstance(state.timeout, str) else state.timeout
                    self._timer = self.after(duration, lambda: self._timeout(state, target))
                return
            if isinstance(state, OutputState):
                self.publisher(state.output).publish(getattr(self, state.message)())
                nxt = state.next
            elif isinstance(state, SideEffect):
                getattr(self, state.action)()
                nxt = state.next
            elif isinstance(state, ConditionalDispatch):
                nxt = state.then if getattr(self, state.predicate)() else state.otherwise
            else:
                raise MachineError(f"{type(self).__qualname__}: unknown state kind {state!r}")
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
            self.state = self._by_name[nxt]
            self.transitions += 1
        raise MachineError(f"{type(self).__qualname__}: {MAX_STEPS} transitions without waiting, "
                           f"last in state {self.state.name!r}; an EventDispatch state must break every loop")

    def _timeout(self, state: State, target: State) -> None:
        if self.state is state:
            self._timer = None
            self._enter(target)
            self.report()

    def report(self) -> None:
        """Publish the state and the registers on ``~afsm`` (latched): the machine as it waits now."""
        self._state_publisher.publish(self.status())

    def status(self) -> DiagnosticStatus:
        """The machine's state, transition count and registers (one short line each) as a diagnostic."""
        values = [KeyValue("state", self.state.name), KeyValue("kind", self.state.kind),
                  KeyValue("transitions", str(self.transitions)), KeyValue("time", f"{self.now():.3f}")]
        values += [KeyValue(f"register {name}", "none" if value is None else brief(value))
                   for name, value in vars(self.registers).items()]
        return DiagnosticStatus(DiagnosticStatus.OK, self.node.name, f"state {self.state.name}", "", values)

    # Showing --------------------------------------------------------------------------------------
    @classmethod
    def describe_machine(cls) -> str:
        """The machine as text: one line per state with its kind and transitions."""
        lines = [f"AFSM {cls.__qualname__}"]
        for state in cls.states:
            moves = ", ".join(f"{label} -> {target}" for label, target in state.targets().items())
            lines.append(f"  {state.name:<12} [{state.kind}]  {moves}")
        return "\n".join(lines)

    @classmethod
    def to_dot(cls) -> str:
        """The state diagram in Graphviz dot; shapes tell the four kinds apart as in Brooks' drawings."""
        shapes = {"output": "box", "side effect": "ellipse", "conditional dispatch": "diamond",
                  "event dispatch": "doublecircle"}
        lines = [f'digraph "{cls.__qualname__}" {{', '  rankdir=LR; node [fontname="Helvetica"];',
                 '  edge [fontname="Helvetica", fontsize=10];']
        for state in cls.states:
            lines.append(f'  "{state.name}" [shape={shapes[state.kind]}, xlabel="{state.kind}"];')
        lines.append(f'  "__start" [shape=point]; "__start" -> "{cls.states[0].name}";')
        for state in cls.states:
            for label, target in state.targets().items():
                lines.append(f'  "{state.name}" -> "{target}" [label="{label}"];')
        lines.append("}")
        return "\n".join(lines)
