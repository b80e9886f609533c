"""actionlib's wire protocol on a :class:`~subsumption.runtime.NodeHandle`: serve or call an action from a
module, on either runtime, interoperating with ROS's own ``actionlib`` (a real ``SimpleActionClient`` talks
to a module's :class:`ActionServer`; a module's :class:`ActionClient` talks to a real ``actionlib`` server).

Why not ``actionlib`` itself: it is built on rospy (threads, ``rospy.Time``, blocking waits), so it cannot
run in the in-process runtime, where a module must never block and time is simulated. The protocol is small:
for an action called ``NAME`` (resolved like any topic: ``move_base`` in node ``/move_base`` is
``/move_base``), the client publishes ``NAME/goal`` (``<Action>ActionGoal``) and ``NAME/cancel``
(``actionlib_msgs/GoalID``); the server publishes ``NAME/status`` (``actionlib_msgs/GoalStatusArray``,
periodically), ``NAME/feedback`` and ``NAME/result``. Goal states are ``actionlib_msgs/GoalStatus``'s.

Serving (a module that owns the robot's base, say)::

    from move_base_msgs.msg import MoveBaseAction, MoveBaseResult
    from subsumption.actions import ActionServer

    class Mover(Module):
        def setup(self):
            # one goal at a time: a new goal preempts the active one (like move_base)
            self.server = ActionServer(self.node, "move_base", MoveBaseAction, self.on_goal,
                                       on_cancel=self.on_cancel, single_goal=True)

        def on_goal(self, handle):        # handle.goal is a MoveBaseGoal
            handle.accept()               # or handle.reject("why")
            self.active = handle          # later: handle.succeed(MoveBaseResult(), "reached")
                                          #        handle.abort(text="no path"), handle.feedback(fb)
        def on_cancel(self, handle):
            self.stop()
            handle.cancelled(text="cancelled by the client")   # PREEMPTED (RECALLED if not yet active)

Calling (the patrol level sending goals)::

    from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
    from subsumption.actions import ActionClient, GoalStatus

    self.client = ActionClient(self.node, "move_base", MoveBaseAction)
    goal = self.client.send_goal(MoveBaseGoal(target_pose=pose_stamped), done=self.on_done,
                                 feedback=self.on_feedback)
    ...
    def on_done(self, goal):              # goal is the ClientGoal returned by send_goal
        if goal.status == GoalStatus.SUCCEEDED: ...
        print(goal.status_name, goal.text, goal.result)
    goal.cancel()                          # or self.client.cancel_all()

Nothing blocks: :meth:`ActionClient.send_goal` before the server is up keeps the goal and sends it when the
server's first status arrives; a goal the server has not acknowledged within ``resend_after`` seconds is sent
again with the same id (servers ignore an id they know), which covers ROS connections still being set up.
Callbacks run on the module's own thread of control (the NodeHandle serialises them), never concurrently.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any, Callable

import genpy
from actionlib_msgs.msg import GoalID, GoalStatus, GoalStatusArray
from std_msgs.msg import Header

from .runtime import Message, NodeHandle, TimerHandle

__all__ = ["ActionClient", "ActionServer", "ActionTypes", "ClientGoal", "GoalStatus", "ServerGoal",
           "STATUS_NAMES", "TERMINAL"]

STATUS_NAMES = {GoalStatus.PENDING: "PENDING", GoalStatus.ACTIVE: "ACTIVE", GoalStatus.PREEMPTED: "PREEMPTED",
                GoalStatus.SUCCEEDED: "SUCCEEDED", GoalStatus.ABORTED: "ABORTED", GoalStatus.REJECTED: "REJECTED",
                GoalStatus.PREEMPTING: "PREEMPTING", GoalStatus.RECALLING: "RECALLING",
                GoalStatus.RECALLED: "RECALLED", GoalStatus.LOST: "LOST"}
TERMINAL = frozenset({GoalStatus.PREEMPTED, GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.REJECTED,
                      GoalStatus.RECALLED, GoalStatus.LOST})


class ActionError(RuntimeError):
    """A goal handle used against the protocol (e.g. succeeding a goal twice); the message names the goal."""


@dataclass(frozen=True)
class ActionTypes:
    """The seven message classes of one action, from its ``<Name>Action`` class (as actionlib finds them)."""

    action: type
    action_goal: type
    action_result: type
    action_feedback: type
    goal: type
    result: type
    feedback: type

    @classmethod
    def of(cls, action_type: type) -> "ActionTypes":
        """The goal, result and feedback message types of an actionlib action type (``MoveBaseAction``); a TypeError for
        a message that is not an action."""
        spec = action_type()
        try:
            ag, ar, af = type(spec.action_goal), type(spec.action_result), type(spec.action_feedback)
        except AttributeError:
            raise TypeError(f"{action_type!r} is not an actionlib action message (needs action_goal, "
                            f"action_result, action_feedback)") from None
        return cls(action_type, ag, ar, af, type(ag().goal), type(ar().result), type(af().feedback))


def _time(seconds: float) -> genpy.Time:
    return genpy.Time.from_sec(max(seconds, 0.0))


def _topic(name: str, sub: str) -> str:
    return f"{name.rstrip('/')}/{sub}"


# Server side --------------------------------------------------------------------------------------------

@dataclass(eq=False)
class ServerGoal:
    """One goal as the server sees it: :attr:`goal` (the action's Goal message), :attr:`id`, :attr:`status`.
    Move it along with :meth:`accept`, :meth:`reject`, :meth:`succeed`, :meth:`abort`, :meth:`cancelled`;
    send progress with :meth:`feedback`."""

    server: "ActionServer"
    goal_id: GoalID
    goal: Message
    status: int = GoalStatus.PENDING
    text: str = ""
    cancel_requested: bool = False
    done_at: float | None = None

    @property
    def id(self) -> str:
        """The goal's id (actionlib's ``goal_id.id``), the key clients cancel by."""
        return self.goal_id.id

    @property
    def active(self) -> bool:
        """Pending or being worked on (including while a cancel is being processed)."""
        return self.status not in TERMINAL

    def accept(self, text: str = "") -> None:
        """PENDING -> ACTIVE (PREEMPTING if a cancel already came in)."""
        if self.status == GoalStatus.PENDING:
            self._set(GoalStatus.ACTIVE, text)
        elif self.status == GoalStatus.RECALLING:
            self._set(GoalStatus.PREEMPTING, text)
        elif self.status not in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING):
            raise ActionError(f"{self.server.name}: goal {self.id} cannot be accepted in state "
                              f"{STATUS_NAMES[self.status]}")
        self.server._publish_status()

    def reject(self, text: str = "", result: Message | None = None) -> None:
        """A goal the server will not try: REJECTED (only before it was accepted)."""
        self._finish({GoalStatus.PENDING, GoalStatus.RECALLING}, GoalStatus.REJECTED, result, text)

    def succeed(self, result: Message | None = None, text: str = "") -> None:
        """End an active or preempting goal as SUCCEEDED, with its result and a text for the client."""
        self._finish({GoalStatus.ACTIVE, GoalStatus.PREEMPTING}, GoalStatus.SUCCEEDED, result, text)

    def abort(self, result: Message | None = None, text: str = "") -> None:
        """The server tried and gave up: ABORTED with `text` saying why."""
        self._finish({GoalStatus.ACTIVE, GoalStatus.PREEMPTING}, GoalStatus.ABORTED, result, text)

    def cancelled(self, result: Message | None = None, text: str = "") -> None:
        """Stopped on a cancel request or a newer goal: PREEMPTED if it was active, RECALLED if still pending."""
        if self.status in (GoalStatus.PENDING, GoalStatus.RECALLING):
            self._finish({self.status}, GoalStatus.RECALLED, result, text)
        else:
            self._finish({GoalStatus.ACTIVE, GoalStatus.PREEMPTING}, GoalStatus.PREEMPTED, result, text)

    def feedback(self, feedback: Message) -> None:
        """Publish progress (the action's Feedback message) for this goal."""
        if not self.active:
            return
        server = self.server
        msg = server.types.action_feedback(header=server._header(), status=self._status_msg(), feedback=feedback)
        server._feedback_pub.publish(msg)

    def _status_msg(self) -> GoalStatus:
        return GoalStatus(goal_id=self.goal_id, status=self.status, text=self.text)

    def _set(self, status: int, text: str) -> None:
        self.status = status
        if text:
            self.text = text

    def _finish(self, allowed: set[int], status: int, result: Message | None, text: str) -> None:
        if self.status not in allowed:
            raise ActionError(f"{self.server.name}: goal {self.id} cannot become {STATUS_NAMES[status]} from "
                              f"{STATUS_NAMES[self.status]}")
        self._set(status, text)
        self.done_at = self.server.node.now()
        server = self.server
        msg = server.types.action_result(header=server._header(), status=self._status_msg(),
                                         result=result if result is not None else server.types.result())
        server._result_pub.publish(msg)
        server._publish_status()


class ActionServer:
    """The server end of action `name` on `node`: calls ``on_goal(ServerGoal)`` for every new goal and
    ``on_cancel(ServerGoal)`` when a client asks to cancel one that is still going (without ``on_cancel`` the
    goal is marked cancelled at once). With `single_goal` (actionlib's SimpleActionServer policy, move_base's)
    a new goal first preempts every goal still going (PREEMPTED, text "preempted by a newer goal"), and
    ``on_preempt(old, new)`` is called before that if given, so the module can stop what the old goal started.

    Status is published every 1/`status_frequency` s; finished goals stay listed `status_list_timeout` s."""

    def __init__(self, node: NodeHandle, name: str, action_type: type,
                 on_goal: Callable[[ServerGoal], None], on_cancel: Callable[[ServerGoal], None] | None = None,
                 single_goal: bool = False, on_preempt: Callable[[ServerGoal, ServerGoal], None] | None = None,
                 status_frequency: float = 5.0, status_list_timeout: float = 5.0) -> None:
        self.node = node
        self.name = node.resolve(name)
        self.types = ActionTypes.of(action_type)
        self.on_goal, self.on_cancel, self.on_preempt = on_goal, on_cancel, on_preempt
        self.single_goal = single_goal
        self.status_list_timeout = status_list_timeout
        self.goals: dict[str, ServerGoal] = {}
        self._early_cancels: dict[str, float] = {}  # goal id -> when its cancel came, before the goal did
        self.last_cancel = 0.0  # stamp of the last cancel-everything-before request
        self._ids = itertools.count(1)
        self._status_pub = node.publisher(_topic(self.name, "status"), GoalStatusArray)
        self._feedback_pub = node.publisher(_topic(self.name, "feedback"), self.types.action_feedback)
        self._result_pub = node.publisher(_topic(self.name, "result"), self.types.action_result)
        node.subscribe(_topic(self.name, "goal"), self.types.action_goal, self._on_goal_msg)
        node.subscribe(_topic(self.name, "cancel"), GoalID, self._on_cancel_msg)
        self._timer: TimerHandle = node.call_every(1.0 / status_frequency, self._publish_status)

    def active_goals(self) -> list[ServerGoal]:
        """The goals still under way (accepted, not yet ended), oldest first."""
        return [g for g in self.goals.values() if g.active]

    def _header(self) -> Header:
        return Header(0, _time(self.node.now()), "")

    def _on_goal_msg(self, msg: Message) -> None:
        goal_id = msg.goal_id
        if not goal_id.id:  # actionlib gives an anonymous goal an id of its own
            goal_id = GoalID(stamp=goal_id.stamp, id=f"{self.node.name}-{next(self._ids)}-{self.node.now():.3f}")
        if goal_id.id in self.goals:
            return  # a resend: already known
        if goal_id.stamp == genpy.Time():
            goal_id = GoalID(stamp=_time(self.node.now()), id=goal_id.id)
        handle = ServerGoal(self, goal_id, msg.goal)
        self.goals[goal_id.id] = handle
        if goal_id.id in self._early_cancels or (
                msg.goal_id.stamp != genpy.Time() and msg.goal_id.stamp.to_sec() <= self.last_cancel):
            self._early_cancels.pop(goal_id.id, None)
            handle.cancelled(text="cancelled before it arrived")
            return
        if self.single_goal:
            for old in self.active_goals():
                if old is handle:
                    continue
                if self.on_preempt is not None:
                    self.on_preempt(old, handle)
                if old.active:
                    old.cancelled(text="preempted by a newer goal")
        self.on_goal(handle)

    def _on_cancel_msg(self, msg: GoalID) -> None:
        stamp = msg.stamp.to_sec()
        everything = not msg.id and stamp == 0.0
        if stamp > 0.0:
            self.last_cancel = max(self.last_cancel, stamp)
        for handle in list(self.goals.values()):
            hit = everything or handle.id == msg.id or (stamp > 0.0 and handle.goal_id.stamp.to_sec() <= stamp)
            if not hit or not handle.active or handle.cancel_requested:
                continue
            handle.cancel_requested = True
            if handle.status == GoalStatus.PENDING:
                handle.status = GoalStatus.RECALLING
            elif handle.status == GoalStatus.ACTIVE:
                handle.status = GoalStatus.PREEMPTING
            if self.on_cancel is not None:
                self.on_cancel(handle)
            elif handle.active:
                handle.cancelled(text="cancelled")
        if msg.id and msg.id not in self.goals:  # a cancel ahead of its goal: remember it a while
            self._early_cancels[msg.id] = self.node.now()
        self._publish_status()

    def _publish_status(self) -> None:
        now = self.node.now()
        for key in [k for k, g in self.goals.items()
                    if g.done_at is not None and now - g.done_at > self.status_list_timeout]:
            del self.goals[key]
        for key in [k for k, t in self._early_cancels.items() if now - t > self.status_list_timeout]:
            del self._early_cancels[key]
        self._status_pub.publish(GoalStatusArray(header=self._header(),
                                                 status_list=[g._status_msg() for g in self.goals.values()]))


# Client side --------------------------------------------------------------------------------------------

@dataclass(eq=False)
class ClientGoal:
    """One goal as the client sees it. :attr:`status` is the latest GoalStatus the server reported
    (PENDING until then), :attr:`done` whether it is terminal, :attr:`result` the Result message once done,
    :attr:`text` the server's reason."""

    client: "ActionClient"
    goal_id: GoalID
    goal: Message
    done_cb: Callable[["ClientGoal"], None] | None = None
    active_cb: Callable[["ClientGoal"], None] | None = None
    feedback_cb: Callable[["ClientGoal", Message], None] | None = None
    status: int = GoalStatus.PENDING
    text: str = ""
    result: Message | None = None
    last_feedback: Message | None = None
    sent_at: float | None = None
    acknowledged: bool = False
    done: bool = False
    _active_told: bool = field(default=False, repr=False)

    @property
    def id(self) -> str:
        """The goal's id (actionlib's ``goal_id.id``)."""
        return self.goal_id.id

    @property
    def status_name(self) -> str:
        """The goal's status as actionlib names it (``ACTIVE``, ``SUCCEEDED``, ...), for logs and metrics."""
        return STATUS_NAMES.get(self.status, str(self.status))

    def cancel(self) -> None:
        """Ask the server to cancel this goal; the result (PREEMPTED or RECALLED) arrives later."""
        self.client._cancel_pub.publish(GoalID(stamp=genpy.Time(), id=self.id))


class ActionClient:
    """The client end of action `name` on `node` (see the module docstring for an example).

    `resend_after`: seconds after which a goal the server has not listed yet is sent again (same id)."""

    def __init__(self, node: NodeHandle, name: str, action_type: type, resend_after: float = 1.0) -> None:
        self.node = node
        self.name = node.resolve(name)
        self.types = ActionTypes.of(action_type)
        self.resend_after = resend_after
        self.goals: dict[str, ClientGoal] = {}
        self.server_seen = False
        self._ids = itertools.count(1)
        self._goal_pub = node.publisher(_topic(self.name, "goal"), self.types.action_goal)
        self._cancel_pub = node.publisher(_topic(self.name, "cancel"), GoalID)
        node.subscribe(_topic(self.name, "status"), GoalStatusArray, self._on_status)
        node.subscribe(_topic(self.name, "feedback"), self.types.action_feedback, self._on_feedback)
        node.subscribe(_topic(self.name, "result"), self.types.action_result, self._on_result)
        self._timer: TimerHandle | None = None

    def send_goal(self, goal: Message, done: Callable[[ClientGoal], None] | None = None,
                  active: Callable[[ClientGoal], None] | None = None,
                  feedback: Callable[[ClientGoal, Message], None] | None = None) -> ClientGoal:
        """Send `goal` (the action's Goal message). `done(goal)` is called once with the terminal status,
        `active(goal)` when the server starts on it, `feedback(goal, msg)` on each feedback."""
        if not isinstance(goal, self.types.goal):
            raise TypeError(f"{self.name}: goal must be {self.types.goal.__name__}, got {type(goal).__name__}")
        now = self.node.now()
        goal_id = GoalID(stamp=_time(now), id=f"{self.node.name}-{next(self._ids)}-{now:.3f}")
        handle = ClientGoal(self, goal_id, goal, done, active, feedback)
        self.goals[goal_id.id] = handle
        if self.server_seen:
            self._send(handle)
        if self._timer is None:
            self._timer = self.node.call_every(max(self.resend_after / 2, 0.05), self._resend)
        return handle

    def cancel_all(self) -> None:
        """Cancel every goal on the server (actionlib's cancel_all_goals)."""
        self._cancel_pub.publish(GoalID(stamp=genpy.Time(), id=""))

    def pending(self) -> list[ClientGoal]:
        """Goals sent and not yet done."""
        return [g for g in self.goals.values() if not g.done]

    def _send(self, handle: ClientGoal) -> None:
        handle.sent_at = self.node.now()
        self._goal_pub.publish(self.types.action_goal(header=Header(0, handle.goal_id.stamp, ""),
                                                      goal_id=handle.goal_id, goal=handle.goal))

    def _resend(self) -> None:
        now = self.node.now()
        for handle in self.pending():
            if handle.acknowledged or not self.server_seen:
                continue
            if handle.sent_at is None or now - handle.sent_at >= self.resend_after:
                self._send(handle)

    def _on_status(self, msg: GoalStatusArray) -> None:
        first = not self.server_seen
        self.server_seen = True
        for status in msg.status_list:
            handle = self.goals.get(status.goal_id.id)
            if handle is None or handle.done:
                continue
            handle.acknowledged = True
            self._update(handle, status)
        if first:
            for handle in self.pending():
                if handle.sent_at is None:
                    self._send(handle)

    def _update(self, handle: ClientGoal, status: GoalStatus) -> None:
        if status.status in TERMINAL:
            return  # terminal states are taken from the result message, which carries the Result
        handle.status, handle.text = status.status, status.text or handle.text
        if status.status in (GoalStatus.ACTIVE, GoalStatus.PREEMPTING) and not handle._active_told:
            handle._active_told = True
            if handle.active_cb is not None:
                handle.active_cb(handle)

    def _on_feedback(self, msg: Message) -> None:
        handle = self.goals.get(msg.status.goal_id.id)
        if handle is None or handle.done:
            return
        handle.acknowledged = True
        self._update(handle, msg.status)
        handle.last_feedback = msg.feedback
        if handle.feedback_cb is not None:
            handle.feedback_cb(handle, msg.feedback)

    def _on_result(self, msg: Message) -> None:
        handle = self.goals.get(msg.status.goal_id.id)
        if handle is None or handle.done:
            return
        handle.acknowledged = True
        handle.status, handle.text, handle.result = msg.status.status, msg.status.text, msg.result
        handle.done = True
        if handle.done_cb is not None:
            handle.done_cb(handle)


def status_name(status: int) -> str:
    """'SUCCEEDED' for GoalStatus.SUCCEEDED, and so on."""
    return STATUS_NAMES.get(status, str(status))


def describe(handle: Any) -> str:
    """'<id>: <STATUS> (<text>)' for a ServerGoal or ClientGoal, for logs."""
    text = f" ({handle.text})" if handle.text else ""
    return f"{handle.id}: {status_name(handle.status)}{text}"
