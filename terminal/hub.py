"""The asyncio side of the terminal: clients, their subscriptions, control, and the hand-off from ROS.

Threads: rospy delivers each topic on a thread of its own; the web server runs one asyncio loop on another.
They meet in :meth:`Hub.offer`, the only method the ROS threads call: it encodes the message to JSON *on the
ROS thread* (once, whatever the number of clients), appends it to the channel's small pending queue under a
lock, and wakes the loop with ``call_soon_threadsafe`` only if no wake-up is pending already, so a fast
topic can never pile up callbacks on a slow loop. Everything else runs on the loop.

Each client has a sender task and, per subscription, a bounded queue (the newest message wins for camera
frames and poses; alarms keep up to 50): a client that reads slowly only loses its own stale frames, and a
client that does not read at all blocks only its own sender until ``~send_timeout``, when it is closed.
"""
from __future__ import annotations

import asyncio
import itertools
import logging
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Protocol

import genpy
import roslib.message

from . import protocol, rosapi
from .config import Config
from .control import ControlLease, TokenBucket
from .convert import MessageError, dumps, from_json, normalise_type, to_json
from .expose import Exposure, keep_for
from .protocol import Op, ProtocolError
from .security import token_matches
from .topics import Role

LOG = logging.getLogger("terminal")
CONTROL_ID = "terminal/control"


@dataclass
class Encoded:
    """A message as it goes out: its JSON once, and for camera frames the JPEG bytes for MJPEG viewers."""

    msg_json: str
    jpeg: bytes | None = None
    stamp: float = 0.0  # header stamp, seconds (for latency figures)
    source: Any = field(default=None, repr=False, compare=False)  # the ROS message it was made from


def encode_message(msg: genpy.Message) -> Encoded:
    """A ROS message encoded once as rosbridge JSON, with its stamp, for every client that wants it."""
    stamp = getattr(getattr(msg, "header", None), "stamp", None)
    return Encoded(dumps(to_json(msg)), stamp=stamp.to_sec() if stamp is not None else 0.0, source=msg)


class CommandSink(Protocol):
    """What the hub needs from the ROS side (implemented by :class:`terminal.ros_side.RosSide`)."""

    def publish_command(self, role: str, msg: genpy.Message) -> None:
        """Publish an operator's command for `role` (cmd_vel, target, stop, ...) on the robot's topic."""
    def halt(self, reason: str) -> bool:
        """Stop the robot (a zero Twist) because of `reason`; True if it was moving."""
    def publish_status(self, summary: dict[str, Any]) -> None:
        """Publish the terminal's summary (operator, clients, viewers) on its status topic."""
    def sync_topic(self, channel: Channel) -> None:
        """Subscribe an exposed topic on the ROS side while a client wants it, unsubscribe it when none does
        (called on a worker thread: registering with the master blocks)."""


class Channel:
    """One exposed topic as clients see it: the newest message, who subscribes, who streams it."""

    def __init__(self, role: Role, name: str, encode: Callable[[Any], Encoded] = encode_message) -> None:
        self.role = role
        self.name = name
        self.type = role.type
        self.encode = encode
        self.subscriptions: set[Subscription] = set()
        self.streams = 0
        self.latest: Encoded | None = None
        self.latest_source: Any = None   # the ROS message `latest` was made from
        self.latest_raw: Any = None      # the newest ROS message, encoded or not (set by ROS threads)
        self.received = 0
        self.seq = 0
        self.pending: deque[Encoded] = deque(maxlen=max(1, role.keep))
        self.scheduled = False
        self.frame_event: asyncio.Event | None = None

    @property
    def wanted(self) -> bool:
        """True while a client subscribes to the topic or streams it."""
        return bool(self.subscriptions) or self.streams > 0

    async def next_frame(self, after: int) -> tuple[int, Encoded]:
        """Wait for a message newer than sequence number `after` (MJPEG streams)."""
        while self.seq <= after or self.latest is None:
            if self.frame_event is None:
                self.frame_event = asyncio.Event()
            await self.frame_event.wait()
        return self.seq, self.latest


@dataclass(eq=False)
class Subscription:
    session: Session
    channel: Channel
    name: str                 # the topic as the client spelt it: rosbridge clients match replies by it
    queue: deque
    throttle: float = 0.0     # seconds between messages (rosbridge's throttle_rate, in ms on the wire)
    due: float = 0.0
    ids: set | None = None

    def push(self, encoded: Encoded) -> None:
        """Queue an encoded message for the client and wake its sender."""
        self.queue.append(encoded)
        self.session.wake()


class Session:
    """One WebSocket client."""

    def __init__(self, hub: Hub, client_id: int, peer: str, send: Callable[[str], Any], close: Callable[[str], Any],
                 authenticated: bool, now: float) -> None:
        self.hub = hub
        self.id = client_id
        self.peer = peer
        self._send = send
        self._close = close
        self.authenticated = authenticated
        self.connected_at = now
        self.level = "error"
        self.subscriptions: dict[str, Subscription] = {}
        self.advertised: set[str] = set()
        self.target_set = False  # this client's manual target is out (cleared when it hands control back)
        self.control: deque[str] = deque(maxlen=100)
        self.bucket = TokenBucket(hub.config.max_rate, hub.config.burst, now)
        self.flood_dropped = 0
        self._flood_reported_at = -1e9
        self._wake = asyncio.Event()
        self._rotation = 0
        self.closed = False
        self.sending = False  # a send is in flight (wait_for runs it as a task of its own)
        self.sent = 0

    def wake(self) -> None:
        """Wake the session's sender (something to send, or closed)."""
        self._wake.set()

    def notify(self, level: str, text: str, op_id: Any = None) -> None:
        """Queue a status message if the client's level (rosbridge set_level) lets it through."""
        if protocol.level_allows(self.level, level):
            self.control.append(protocol.status(level, text, op_id))
            self.wake()

    def reply(self, text: str) -> None:
        """Queue a protocol reply to this client."""
        self.control.append(text)
        self.wake()

    @property
    def replies_pending(self) -> bool:
        """True while replies wait to be sent or one is being sent."""
        return bool(self.control) or self.sending

    def _next(self, now: float) -> tuple[str | None, float | None]:
        """The next text to send, and when to look again if only throttled messages wait."""
        if self.control:
            return self.control.popleft(), None
        subscriptions = list(self.subscriptions.values())
        earliest = None
        for offset in range(len(subscriptions)):
            sub = subscriptions[(self._rotation + offset) % len(subscriptions)]
            if not sub.queue:
                continue
            if now < sub.due:
                earliest = sub.due if earliest is None else min(earliest, sub.due)
                continue
            self._rotation = (self._rotation + offset + 1) % len(subscriptions)
            sub.due = now + sub.throttle
            return protocol.publish_text(sub.name, sub.queue.popleft().msg_json), None
        return None, earliest

    async def run_sender(self) -> None:
        """Send what is queued, oldest status first, subscriptions in turn; close a client that takes nothing."""
        loop = asyncio.get_running_loop()
        timeout = self.hub.config.send_timeout
        while not self.closed:
            await self._wake.wait()
            self._wake.clear()
            while not self.closed:
                text, later = self._next(time.monotonic())
                if text is None:
                    if later is not None:
                        loop.call_at(loop.time() + max(0.0, later - time.monotonic()), self._wake.set)
                    break
                self.sending = True
                try:
                    await asyncio.wait_for(self._send(text), timeout)
                except asyncio.TimeoutError:
                    LOG.warning("terminal: client %d (%s) took no data for %.1f s: closing it", self.id, self.peer,
                                timeout)
                    self._close("not reading")
                    return
                except (ConnectionError, RuntimeError):
                    return
                finally:
                    self.sending = False
                self.sent += 1


class Hub:
    """Channels, commands, clients and the lease; every method but :meth:`offer` runs on the loop."""

    def __init__(self, config: Config, channels: list[Channel], commands: dict[str, tuple[Role, str]],
                 resolve: Callable[[str], str], token: str | None) -> None:
        self.config = config
        self.resolve = resolve
        self.token = token
        self.channels = {channel.name: channel for channel in channels}
        self.by_role = {channel.role.role: channel for channel in channels}
        self.commands = {name: role for role, name in commands.values()}  # resolved topic -> role
        self.command_classes = {role.role: roslib.message.get_message_class(role.type) for role, _ in commands.values()}
        self.sessions: dict[int, Session] = {}
        self.lease = ControlLease()
        self.sink: CommandSink | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self._ids = itertools.count(1)
        self._lock = threading.Lock()
        self.stats = {"commands": 0, "refused": 0, "errors": 0, "flood_dropped": 0}
        # the master's node names, for /rosapi/nodes (set by the ROS side; a short XML-RPC call to the master)
        self.node_names: Callable[[], list[str]] = lambda: []
        # graph topics served read-only besides the channels (--expose): what may be, what is (made on demand),
        # and the graph's published topics (name -> type), replaced whole by the ROS side's poll of the master
        self.exposure = Exposure()
        self.exposed: dict[str, Channel] = {}
        self.graph_topics: dict[str, str] = {}

    # ROS threads ---------------------------------------------------------------------------------------
    def offer(self, channel: Channel, msg: Any) -> None:
        """Called on a ROS thread for every message: encode it if anyone watches, and wake the loop once."""
        channel.latest_raw = msg
        channel.received += 1
        if not channel.wanted or self.loop is None:
            return
        try:
            encoded = channel.encode(msg)
        except Exception as error:  # a message that cannot be shown must not kill the subscriber thread
            LOG.warning("terminal: cannot show a message of %s: %s", channel.name, error)
            return
        with self._lock:
            channel.pending.append(encoded)
            schedule = not channel.scheduled
            channel.scheduled = True
        if schedule:
            self.loop.call_soon_threadsafe(self._flush, channel)

    def _flush(self, channel: Channel) -> None:
        with self._lock:
            batch = list(channel.pending)
            channel.pending.clear()
            channel.scheduled = False
        for encoded in batch:
            self._deliver(channel, encoded)

    def _deliver(self, channel: Channel, encoded: Encoded) -> None:
        channel.latest = encoded
        channel.latest_source = encoded.source
        channel.seq += 1
        for sub in channel.subscriptions:
            sub.push(encoded)
        if channel.frame_event is not None:
            event, channel.frame_event = channel.frame_event, None
            event.set()

    def deliver_local(self, channel: Channel | None, msg: genpy.Message) -> None:
        """A message the terminal itself produced (an echoed command, its status), on the loop."""
        if channel is None:
            return
        channel.latest_raw = msg
        channel.received += 1
        self._deliver(channel, encode_message(msg))

    # Sessions ------------------------------------------------------------------------------------------
    def open_session(self, peer: str, send: Callable[[str], Any], close: Callable[[str], Any],
                     authenticated: bool) -> Session:
        """Register a new WebSocket client and return its session."""
        session = Session(self, next(self._ids), peer, send, close, authenticated, time.monotonic())
        self.sessions[session.id] = session
        LOG.info("terminal: client %d connected from %s%s", session.id, peer,
                 "" if authenticated else " (not yet authenticated)")
        self.status_changed()
        return session

    def close_session(self, session: Session) -> None:
        """Forget a client: its subscriptions end and control is released if it held it."""
        session.closed = True
        session.wake()
        for sub in list(session.subscriptions.values()):
            sub.channel.subscriptions.discard(sub)
            self._exposed_changed(sub.channel)
        session.subscriptions.clear()
        self.sessions.pop(session.id, None)
        if self.lease.holds(session.id):
            if self.sink is not None:
                self.sink.halt(f"operator client {session.id} disconnected")
                self._clear_target(session)
            self.lease.release(session.id, time.monotonic())
            self._control_changed()
        LOG.info("terminal: client %d (%s) disconnected", session.id, session.peer)
        self.status_changed()

    def summary(self) -> dict[str, Any]:
        """The terminal's state for the status topic and the page: operator, clients, viewers, counts."""
        now = time.monotonic()
        holder = self.lease.holder
        return {
            "operator": f"client {holder.client_id} ({holder.peer})" if holder else "",
            "clients": len(self.sessions),
            "viewers": sum(1 for s in self.sessions.values() if s.subscriptions),
            "streams": sum(channel.streams for channel in self.channels.values()),
            "control_held_s": round(self.lease.held_s(now), 3),
            **self.stats,
        }

    def status_changed(self) -> None:
        """Publish the summary again (a client came or went, control changed)."""
        if self.sink is not None:
            self.sink.publish_status(self.summary())

    def _control_changed(self) -> None:
        for session in self.sessions.values():
            if self.lease.holds(session.id):
                text = "you hold control"
            else:
                text = self.lease.describe()
            session.notify("info", text, CONTROL_ID)
        self.status_changed()

    def deadman_fired(self) -> None:
        """The dead-man switch stopped the robot: tell the operator and publish the status."""
        holder = self.lease.holder
        if holder is not None and holder.client_id in self.sessions:
            self.sessions[holder.client_id].notify(
                "warning", f"stopped: no motor command for {self.config.deadman_timeout:g} s (dead-man switch)",
                CONTROL_ID)
        self.status_changed()

    # Frames from clients --------------------------------------------------------------------------------
    def receive(self, session: Session, frame: str) -> None:
        """One text frame from a client: rate limit, parse, act; any problem becomes an error reply."""
        now = time.monotonic()
        if not session.bucket.allow(now):
            session.flood_dropped += 1
            self.stats["flood_dropped"] += 1
            if now - session._flood_reported_at >= 1.0:
                session._flood_reported_at = now
                session.reply(protocol.status(
                    "error", f"flood: {session.flood_dropped} messages dropped so far; the limit is "
                             f"{self.config.max_rate:g} messages a second (bursts of {self.config.burst})"))
            return
        try:
            op = protocol.parse(frame, self.config.max_message_bytes)
            if not session.authenticated and op.op != "auth":
                raise ProtocolError("authentication required: send {\"op\": \"auth\", \"mac\": TOKEN} first, "
                                    "or connect with the token (Authorization: Bearer TOKEN, ?token=TOKEN)", op.id)
            try:
                getattr(self, f"_op_{op.op}")(session, op)
            except ProtocolError:
                raise
            except Exception as error:  # a bug of ours must cost one reply, not the connection or the robot
                LOG.exception("terminal: client %d: %s failed", session.id, op.op)
                raise ProtocolError(f"{op.op} failed inside the terminal ({type(error).__name__}: {error}); "
                                    "the message was dropped", op.id) from None
        except ProtocolError as error:
            self.stats["errors"] += 1
            session.reply(protocol.status("error", error.text, error.op_id))

    def binary(self, session: Session) -> None:
        """A binary WebSocket frame: refused with an error reply (the protocol is JSON text)."""
        self.stats["errors"] += 1
        session.reply(protocol.status("error", "binary frame dropped: this terminal speaks JSON text frames"))

    def _channel(self, op: Op) -> Channel:
        name = self.resolve(op.topic)
        channel = self.channels.get(name) or self.exposed.get(name)
        if channel is None and self.exposure.allows(name):
            channel = self._expose(op, name)
        if channel is None:
            raise ProtocolError(f"{op.op}: topic {op.topic} is not exposed by this terminal "
                                f"({len(self.channels)} topics are; GET /config.json lists them; --expose "
                                f"serves others read-only)", op.id)
        _check_type(op, name, channel.type)
        return channel

    def _expose(self, op: Op, name: str) -> Channel:
        """A channel for a graph topic that --expose allows: its type from the master, else from the client."""
        msg_type = self.graph_topics.get(name) or normalise_type(op.fields.get("type") or "")
        if not msg_type:
            raise ProtocolError(f"{op.op}: nobody publishes {op.topic} yet, so its type is unknown: give it "
                                f"(\"type\": \"pkg/Type\")", op.id)
        if roslib.message.get_message_class(msg_type) is None:
            raise ProtocolError(f"{op.op}: topic {op.topic} carries {msg_type}, a type unknown on this machine",
                                op.id)
        channel = Channel(Role(f"expose:{name}", name, msg_type, keep=keep_for(msg_type),
                               doc="a graph topic served read-only (--expose)"), name)
        self.exposed[name] = channel
        return channel

    def _exposed_changed(self, channel: Channel) -> None:
        """An exposed channel gained its first or lost its last client: the ROS side follows, off the loop."""
        if self.exposed.get(channel.name) is not channel or self.sink is None:
            return
        if not channel.wanted:  # a later client gets what ROS gives it (a latched topic's message), nothing stale
            channel.latest = channel.latest_source = channel.latest_raw = None
        loop = self.loop or asyncio.get_running_loop()
        loop.run_in_executor(None, self.sink.sync_topic, channel)

    def served_topics(self) -> dict[str, str]:
        """Every topic a client may subscribe to now (name -> type): the channels, and the exposed graph topics."""
        topics = {name: msg_type for name, msg_type in self.graph_topics.items() if self.exposure.allows(name)}
        topics.update((name, channel.type) for name, channel in self.exposed.items())
        topics.update((channel.name, channel.type) for channel in self.channels.values())
        return topics

    def _command(self, op: Op) -> Role:
        name = self.resolve(op.topic)
        role = self.commands.get(name)
        if role is None:
            allowed = ", ".join(sorted(self.commands))
            if name in self.exposed or (name not in self.channels and self.exposure.allows(name)):
                raise ProtocolError(f"{op.op}: topic {op.topic} is exposed read-only by this terminal (subscribe "
                                    f"only); only the operator's commands can be published ({allowed})", op.id)
            raise ProtocolError(f"{op.op}: topic {op.topic} cannot be published through this terminal "
                                f"(only {allowed})", op.id)
        _check_type(op, name, role.type)
        return role

    def _take_control(self, session: Session, op: Op) -> None:
        had = self.lease.holds(session.id)
        refusal = self.lease.acquire(session.id, session.peer, time.monotonic())
        if refusal is not None:
            self.stats["refused"] += 1
            raise ProtocolError(f"{op.op} {op.topic}: {refusal}", op.id)
        if not had:
            LOG.info("terminal: client %d (%s) took control", session.id, session.peer)
            self._control_changed()

    def _op_auth(self, session: Session, op: Op) -> None:
        if self.token is None or session.authenticated:
            session.notify("info", "authenticated", op.id)
            session.authenticated = True
            return
        if not token_matches(op.fields["mac"], self.token):
            LOG.warning("terminal: client %d (%s) sent a wrong token: closing", session.id, session.peer)
            session.reply(protocol.status("error", "authentication failed: wrong token", op.id))
            session._close("authentication failed")
            return
        session.authenticated = True
        session.notify("info", "authenticated", op.id)

    def _op_set_level(self, session: Session, op: Op) -> None:
        session.level = op.fields["level"]

    def _op_call_service(self, session: Session, op: Op) -> None:
        service = op.fields["service"]
        if service not in rosapi.SERVICES:
            session.reply(protocol.service_failure(service, f"service {service} is not offered by this terminal "
                                                   f"(it offers topics, and {', '.join(rosapi.SERVICES)})", op.id))
            return
        topics = self.served_topics()
        try:
            values = rosapi.answer(service, op.fields.get("args") or {}, topics, self.node_names)
        except rosapi.RosapiError as error:
            session.reply(protocol.service_failure(service, str(error), op.id))
            return
        session.reply(protocol.service_response(service, values, op.id))

    def _op_subscribe(self, session: Session, op: Op) -> None:
        channel = self._channel(op)
        throttle = float(op.fields.get("throttle_rate") or 0) / 1000.0
        keep = int(op.fields.get("queue_length") or 0) or channel.role.keep
        keep = max(1, min(keep, 100))
        sub = session.subscriptions.get(channel.name)
        if sub is None:
            sub = Subscription(session, channel, op.topic, deque(maxlen=keep), throttle, ids=set())
            session.subscriptions[channel.name] = sub
            channel.subscriptions.add(sub)
            if len(channel.subscriptions) == 1:
                self._exposed_changed(channel)
            self._send_latest(channel, sub)
            self.status_changed()
        else:  # rosbridge merges subscriptions of one client: the smallest throttle, the longest queue
            sub.throttle = min(sub.throttle, throttle)
            if keep > (sub.queue.maxlen or 1):
                sub.queue = deque(sub.queue, maxlen=keep)
        sub.ids.add(op.id)

    def _send_latest(self, channel: Channel, sub: Subscription) -> None:
        """A new subscriber gets the newest message at once, as from a latched topic (a map is sent once)."""
        if channel.latest is not None and channel.latest_source is channel.latest_raw:
            sub.push(channel.latest)
        elif channel.latest_raw is not None:
            asyncio.get_running_loop().create_task(self._push_current(channel, sub))

    async def _push_current(self, channel: Channel, sub: Subscription) -> None:
        encoded = await self.current(channel)
        if encoded is not None and sub in channel.subscriptions and not sub.queue:
            sub.push(encoded)

    async def current(self, channel: Channel) -> Encoded | None:
        """The newest message of `channel`, encoded; one that arrived while nobody watched is encoded now,
        on a worker thread (a big map must not stall the loop)."""
        raw = channel.latest_raw
        if channel.latest is not None and channel.latest_source is raw:
            return channel.latest
        if raw is None:
            return None
        try:
            encoded = await asyncio.get_running_loop().run_in_executor(None, channel.encode, raw)
        except Exception as error:
            LOG.warning("terminal: cannot show a message of %s: %s", channel.name, error)
            return None
        if channel.latest_raw is raw:
            channel.latest, channel.latest_source = encoded, raw
        return encoded

    def stream_channel(self, topic: str) -> Channel | None:
        """The camera channel a web_video_server-style URL names (the image topic or its /compressed)."""
        camera = self.by_role.get("camera")
        if camera is None or not topic:
            return None
        try:
            name = self.resolve(topic)
        except ValueError:
            return None
        return camera if name in (camera.name, camera.name.removesuffix("/compressed"),
                                  camera.name + "/compressed") else None

    def _op_unsubscribe(self, session: Session, op: Op) -> None:
        name = self.resolve(op.topic)
        sub = session.subscriptions.get(name)
        if sub is None:
            return  # rosbridge ignores unsubscribing what is not subscribed
        if op.id is not None and sub.ids and op.id in sub.ids:
            sub.ids.discard(op.id)
            if sub.ids:
                return
        del session.subscriptions[name]
        sub.channel.subscriptions.discard(sub)
        if not sub.channel.subscriptions:
            self._exposed_changed(sub.channel)
        self.status_changed()

    def _op_advertise(self, session: Session, op: Op) -> None:
        self._command(op)
        self._take_control(session, op)
        session.advertised.add(self.resolve(op.topic))

    def _op_unadvertise(self, session: Session, op: Op) -> None:
        session.advertised.discard(self.resolve(op.topic))

    def _op_publish(self, session: Session, op: Op) -> None:
        role = self._command(op)
        try:
            msg = from_json(self.command_classes[role.role], op.fields.get("msg", {}), f"publish {op.topic}: msg")
        except MessageError as error:
            raise ProtocolError(str(error), op.id) from None
        self._take_control(session, op)
        if role.role == "cmd_vel":
            clamp_twist(msg, self.config.max_linear, self.config.max_angular)
        assert self.sink is not None
        self.sink.publish_command(role.role, msg)
        self.stats["commands"] += 1
        self.deliver_local(self.by_role.get(role.role), msg)
        if role.role == "manual_target":
            session.target_set = msg.width > 0 and msg.height > 0
        if role.role == "release":
            self.sink.halt(f"operator client {session.id} released control")
            self._clear_target(session)
            self.lease.release(session.id, time.monotonic())
            LOG.info("terminal: client %d released control", session.id)
            self._control_changed()

    def _clear_target(self, session: Session) -> None:
        """Control handed back (release or disconnect) while this client's manual target is out: a zero-size
        box on the manual target topic, so the tracker lets it go and the robot's own levels have it back."""
        if not session.target_set or self.sink is None:
            return
        session.target_set = False
        cleared = self.command_classes["manual_target"]()
        self.sink.publish_command("manual_target", cleared)
        self.deliver_local(self.by_role.get("manual_target"), cleared)
        LOG.info("terminal: client %d handed control back: its manual target cleared", session.id)

    def iter_sessions(self) -> Iterator[Session]:
        """The sessions now open (a copy: sessions may close meanwhile)."""
        return iter(list(self.sessions.values()))


def _check_type(op: Op, topic: str, carried: str) -> None:
    """A type the client names must be the topic's (either spelling: pkg/Type or pkg/msg/Type)."""
    wanted = op.fields.get("type")
    if wanted and normalise_type(wanted) != carried:
        raise ProtocolError(f"{op.op}: topic {topic} carries {carried}, not {wanted}", op.id)


def clamp_twist(twist: Any, max_linear: float, max_angular: float) -> None:
    """Keep an operator's Twist within the terminal's limits, whatever the client sent."""
    for vector, limit in ((twist.linear, max_linear), (twist.angular, max_angular)):
        vector.x = min(max(vector.x, -limit), limit)
        vector.y = min(max(vector.y, -limit), limit)
        vector.z = min(max(vector.z, -limit), limit)


def is_motion(twist: Any) -> bool:
    """Whether a Twist moves the robot (any component not zero)."""
    return any(abs(v) > 1e-9 for v in (twist.linear.x, twist.linear.y, twist.linear.z,
                                       twist.angular.x, twist.angular.y, twist.angular.z))
