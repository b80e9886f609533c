"""ROS messages to and from the JSON of the rosbridge v2 protocol, the way rosbridge_library converts them.

Conventions clients rely on (roslibpy, roslibjs): fields by name, nested messages as objects, ``time`` and
``duration`` as ``{"secs", "nsecs"}``, ``uint8[]``/``char[]`` as a base64 string (an image's bytes), every
other array as a list. Floats that are not finite become ``null``: JSON has no NaN, and a browser's
``JSON.parse`` refuses the ``NaN`` that Python would otherwise write.

Incoming messages (an operator's commands) are checked field by field; a bad one raises
:class:`MessageError` naming the field, so the reply can say exactly what was wrong.
"""
from __future__ import annotations

import base64
import json
import math
from typing import Any

import genpy
import roslib.message

INTEGER_RANGES = {
    "int8": (-2**7, 2**7 - 1), "uint8": (0, 2**8 - 1), "byte": (-2**7, 2**7 - 1), "char": (0, 2**8 - 1),
    "int16": (-2**15, 2**15 - 1), "uint16": (0, 2**16 - 1), "int32": (-2**31, 2**31 - 1),
    "uint32": (0, 2**32 - 1), "int64": (-2**63, 2**63 - 1), "uint64": (0, 2**64 - 1),
}
FLOATS = {"float32", "float64"}
BYTE_ARRAYS = {"uint8", "char"}  # arrays of these are bytes in Python 3 and base64 in rosbridge JSON


class MessageError(ValueError):
    """An incoming message that does not fit its type; the text names the field."""


def _base_type(slot_type: str) -> tuple[str, bool]:
    """('float64', True) for 'float64[]' or 'float64[36]'."""
    if slot_type.endswith("]"):
        return slot_type[: slot_type.index("[")], True
    return slot_type, False


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def to_json(msg: genpy.Message) -> dict[str, Any]:
    """The message as plain JSON-able data (dicts, lists, numbers, strings), rosbridge's layout."""
    out: dict[str, Any] = {}
    for slot, slot_type in zip(msg.__slots__, msg._slot_types):
        out[slot] = _value_to_json(getattr(msg, slot), slot_type)
    return out


def _value_to_json(value: Any, slot_type: str) -> Any:
    base, is_array = _base_type(slot_type)
    if is_array:
        if base in BYTE_ARRAYS:
            data = value if isinstance(value, (bytes, bytearray)) else bytes(value)
            return base64.b64encode(data).decode("ascii")
        if base in FLOATS:
            return [_finite(v) for v in value]
        if base in INTEGER_RANGES or base == "bool" or base == "string":
            return value if isinstance(value, list) else list(value)
        return [_value_to_json(item, base) for item in value]
    if base in FLOATS:
        return _finite(value)
    if base in ("time", "duration"):
        return {"secs": value.secs, "nsecs": value.nsecs}
    if isinstance(value, genpy.Message):
        return to_json(value)
    return value


def dumps(data: Any) -> str:
    """Compact JSON (what goes on the wire); `data` must already be finite (see :func:`to_json`)."""
    return json.dumps(data, separators=(",", ":"), allow_nan=False)


def from_json(msg_class: type[genpy.Message], data: Any, where: str = "msg") -> genpy.Message:
    """A message of `msg_class` filled from rosbridge JSON; missing fields keep their defaults.

    Raises MessageError naming the first bad field (unknown name, wrong kind of value, integer out of range).
    """
    msg = msg_class()
    _fill(msg, data, where)
    return msg


def _fill(msg: genpy.Message, data: Any, where: str) -> None:
    if not isinstance(data, dict):
        raise MessageError(f"{where}: expected an object for {msg._type}, got {_kind(data)}")
    slots = dict(zip(msg.__slots__, msg._slot_types))
    for key, value in data.items():
        if key not in slots:
            raise MessageError(f"{where}: {msg._type} has no field {key!r} (fields: {', '.join(slots) or 'none'})")
        field = f"{where}.{key}"
        current = getattr(msg, key)
        setattr(msg, key, _value_from_json(current, slots[key], value, field))


def _value_from_json(current: Any, slot_type: str, value: Any, where: str) -> Any:
    base, is_array = _base_type(slot_type)
    if is_array:
        fixed = slot_type[slot_type.index("[") + 1:-1]
        if base in BYTE_ARRAYS and isinstance(value, str):
            try:
                items: Any = base64.b64decode(value, validate=True)
            except ValueError:
                raise MessageError(f"{where}: expected base64 bytes, got a string that is not base64") from None
        elif isinstance(value, list):
            items = [_value_from_json(None, base, item, f"{where}[{i}]") for i, item in enumerate(value)]
            if base in BYTE_ARRAYS:
                items = bytes(items)
        else:
            raise MessageError(f"{where}: expected a list for {slot_type}, got {_kind(value)}")
        if fixed and len(items) != int(fixed):
            raise MessageError(f"{where}: expected {fixed} items for {slot_type}, got {len(items)}")
        return items
    if base in FLOATS:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise MessageError(f"{where}: expected a number ({base}), got {_kind(value)}")
        if not math.isfinite(value):
            raise MessageError(f"{where}: expected a finite number, got {value!r}")
        return float(value)
    if base in INTEGER_RANGES:
        if isinstance(value, bool) or not isinstance(value, int):
            raise MessageError(f"{where}: expected an integer ({base}), got {_kind(value)}")
        low, high = INTEGER_RANGES[base]
        if not low <= value <= high:
            raise MessageError(f"{where}: {value} is out of range for {base} ({low}..{high})")
        return value
    if base == "bool":
        if not isinstance(value, bool):
            raise MessageError(f"{where}: expected true or false, got {_kind(value)}")
        return value
    if base == "string":
        if not isinstance(value, str):
            raise MessageError(f"{where}: expected a string, got {_kind(value)}")
        return value
    if base in ("time", "duration"):
        if not isinstance(value, dict) or set(value) - {"secs", "nsecs"}:
            raise MessageError(f"{where}: expected {{\"secs\": int, \"nsecs\": int}} for {base}")
        secs = _value_from_json(None, "int32", value.get("secs", 0), f"{where}.secs")
        nsecs = _value_from_json(None, "int32", value.get("nsecs", 0), f"{where}.nsecs")
        return (genpy.Time if base == "time" else genpy.Duration)(secs, nsecs)
    nested = current if isinstance(current, genpy.Message) else _message_class(base, where)()
    _fill(nested, value, where)
    return nested


def _message_class(type_name: str, where: str) -> type[genpy.Message]:
    if type_name == "Header":
        type_name = "std_msgs/Header"
    cls = roslib.message.get_message_class(type_name)
    if cls is None:
        raise MessageError(f"{where}: unknown message type {type_name}")
    return cls


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    if isinstance(value, list):
        return "a list"
    return "an object" if isinstance(value, dict) else type(value).__name__


def normalise_type(type_name: str) -> str:
    """'geometry_msgs/Twist' for 'geometry_msgs/Twist' or ROS 2 style 'geometry_msgs/msg/Twist'."""
    parts = type_name.split("/")
    if len(parts) == 3 and parts[1] == "msg":
        return f"{parts[0]}/{parts[2]}"
    return type_name
