"""The rosbridge v2 JSON protocol, as far as the terminal speaks it: parsing and checking what clients send.

Each WebSocket text frame is one JSON object with an ``op``. Supported: ``auth``, ``advertise``,
``unadvertise``, ``publish``, ``subscribe``, ``unsubscribe``, ``set_level`` and ``call_service`` (answered
with a failed ``service_response``: the terminal offers no services). Replies to a bad frame are rosbridge
``status`` messages (``{"op": "status", "level": "error", "msg": ..., "id": ...}``), and the frame is dropped.

:func:`parse` turns a frame into an :class:`Op` or raises :class:`ProtocolError` with the reply's text. It
only checks the shape of the frame; whether a topic exists or may be published is the hub's business.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from .convert import dumps

SUPPORTED_OPS = ("auth", "advertise", "unadvertise", "publish", "subscribe", "unsubscribe", "set_level",
                 "call_service")
# rosbridge ops that exist but that this terminal does not offer: refused by name, not as unknown
UNSUPPORTED_OPS = ("advertise_service", "unadvertise_service", "service_response", "fragment", "png",
                   "send_action_goal", "cancel_action_goal", "advertise_action", "unadvertise_action",
                   "action_feedback", "action_result")
STATUS_LEVELS = ("none", "error", "warning", "info")
MAX_NAME = 256
NAME_PATTERN = re.compile(r"^[~/]?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*$")
TYPE_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*(/msg)?/[A-Za-z][A-Za-z0-9_]*$")


class ProtocolError(ValueError):
    """A frame that cannot be acted on; `text` is the reply, `op_id` the id to echo (if the frame had one)."""

    def __init__(self, text: str, op_id: Any = None) -> None:
        super().__init__(text)
        self.text = text
        self.op_id = op_id


@dataclass
class Op:
    """One checked operation: its name, the id to echo in replies, and its fields."""

    op: str
    id: Any
    fields: dict[str, Any]

    @property
    def topic(self) -> str:
        """The operation's topic field."""
        return self.fields["topic"]


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not valid JSON")


def parse(frame: str | bytes, max_bytes: int) -> Op:
    """Check one frame: its size, its JSON, its op and the fields that op needs."""
    size = len(frame.encode("utf-8") if isinstance(frame, str) else frame)
    if size > max_bytes:
        raise ProtocolError(f"message of {size} bytes dropped: the limit is {max_bytes} bytes")
    try:
        data = json.loads(frame, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as error:
        raise ProtocolError(f"malformed JSON dropped: {str(error)[:120]}") from None
    if not isinstance(data, dict):
        raise ProtocolError("message dropped: a rosbridge message is a JSON object with an \"op\" field")
    op_id = data.get("id")
    if not isinstance(op_id, (str, int, type(None))) or isinstance(op_id, bool):
        op_id = None
    op = data.get("op")
    if not isinstance(op, str):
        raise ProtocolError("message dropped: it has no \"op\" (a string) field", op_id)
    if op in UNSUPPORTED_OPS:
        raise ProtocolError(f"op {op!r} is not offered by this terminal (it offers: {', '.join(SUPPORTED_OPS)})",
                            op_id)
    if op not in SUPPORTED_OPS:
        raise ProtocolError(f"unknown op {op[:40]!r} dropped (supported: {', '.join(SUPPORTED_OPS)})", op_id)
    fields = {key: value for key, value in data.items() if key not in ("op", "id")}
    _CHECKS[op](fields, op_id)
    return Op(op, op_id, fields)


def _require_name(fields: dict[str, Any], key: str, op: str, op_id: Any) -> None:
    name = fields.get(key)
    if not isinstance(name, str) or not name:
        raise ProtocolError(f"{op}: \"{key}\" (a ROS name) is required", op_id)
    if len(name) > MAX_NAME or not NAME_PATTERN.match(name):
        raise ProtocolError(f"{op}: {key} {name[:60]!r} is not a valid ROS name", op_id)


def _optional_type(fields: dict[str, Any], op: str, op_id: Any, required: bool = False) -> None:
    type_name = fields.get("type")
    if type_name is None and not required:
        return
    if not isinstance(type_name, str) or not TYPE_PATTERN.match(type_name):
        raise ProtocolError(f"{op}: \"type\" must be a message type like geometry_msgs/Twist, "
                            f"got {str(type_name)[:60]!r}", op_id)


def _optional_count(fields: dict[str, Any], key: str, op: str, op_id: Any) -> None:
    value = fields.get(key)
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 or value != value:
        raise ProtocolError(f"{op}: \"{key}\" must be a number >= 0, got {value!r}", op_id)


def _check_topic(fields: dict[str, Any], op_id: Any, op: str) -> None:
    _require_name(fields, "topic", op, op_id)


def _check_advertise(fields: dict[str, Any], op_id: Any) -> None:
    _require_name(fields, "topic", "advertise", op_id)
    _optional_type(fields, "advertise", op_id, required=True)


def _check_publish(fields: dict[str, Any], op_id: Any) -> None:
    _require_name(fields, "topic", "publish", op_id)
    if not isinstance(fields.get("msg", {}), dict):
        raise ProtocolError("publish: \"msg\" must be a JSON object (the message's fields)", op_id)


def _check_subscribe(fields: dict[str, Any], op_id: Any) -> None:
    _require_name(fields, "topic", "subscribe", op_id)
    _optional_type(fields, "subscribe", op_id)
    for key in ("throttle_rate", "queue_length", "fragment_size"):
        _optional_count(fields, key, "subscribe", op_id)
    compression = fields.get("compression", "none")
    if compression not in ("none", None):
        raise ProtocolError(f"subscribe: compression {str(compression)[:20]!r} is not offered (only \"none\")",
                            op_id)


def _check_auth(fields: dict[str, Any], op_id: Any) -> None:
    if not isinstance(fields.get("mac"), str):
        raise ProtocolError("auth: \"mac\" (the token, a string) is required", op_id)


def _check_set_level(fields: dict[str, Any], op_id: Any) -> None:
    if fields.get("level") not in STATUS_LEVELS:
        raise ProtocolError(f"set_level: \"level\" must be one of {', '.join(STATUS_LEVELS)}", op_id)


def _check_call_service(fields: dict[str, Any], op_id: Any) -> None:
    _require_name(fields, "service", "call_service", op_id)


_CHECKS = {
    "auth": _check_auth,
    "advertise": _check_advertise,
    "unadvertise": lambda fields, op_id: _check_topic(fields, op_id, "unadvertise"),
    "publish": _check_publish,
    "subscribe": _check_subscribe,
    "unsubscribe": lambda fields, op_id: _check_topic(fields, op_id, "unsubscribe"),
    "set_level": _check_set_level,
    "call_service": _check_call_service,
}


def status(level: str, text: str, op_id: Any = None) -> str:
    """A rosbridge status message (the reply to a frame that went wrong, or a notice)."""
    reply: dict[str, Any] = {"op": "status", "level": level, "msg": text}
    if op_id is not None:
        reply["id"] = op_id
    return dumps(reply)


def service_failure(service: str, text: str, op_id: Any = None) -> str:
    """The answer to a call_service: rosbridge's failed service_response."""
    reply: dict[str, Any] = {"op": "service_response", "service": service, "values": text, "result": False}
    if op_id is not None:
        reply["id"] = op_id
    return dumps(reply)


def service_response(service: str, values: dict[str, Any], op_id: Any = None) -> str:
    """A successful call_service's answer: rosbridge's service_response with the response's fields."""
    reply: dict[str, Any] = {"op": "service_response", "service": service, "values": values, "result": True}
    if op_id is not None:
        reply["id"] = op_id
    return dumps(reply)


def publish_text(topic: str, msg_json: str) -> str:
    """The publish op carrying an already encoded message: encoded once, sent to every subscriber."""
    return '{"op":"publish","topic":' + json.dumps(topic) + ',"msg":' + msg_json + "}"


def level_allows(client_level: str, message_level: str) -> bool:
    """rosbridge's set_level: a client at level L receives status messages of L and more severe ones."""
    order = {"error": 1, "warning": 2, "info": 3}
    if client_level == "none":
        return False
    return order[message_level] <= order[client_level]
