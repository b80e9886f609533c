"""One-line summaries of ROS messages, for status topics and terminal views.

A register may hold a 541-beam LaserScan; a status line must stay short and cheap to make at sensor rate. So
numbers are shown to four significant figures, arrays longer than a few items by their length, headers by
their stamp and frame only, and the whole line is cut at a fixed length.
"""
from __future__ import annotations

from typing import Any

MAX_ITEMS = 4      # arrays longer than this are shown as "[N items]"
MAX_LENGTH = 160   # characters of a whole summary


def brief(msg: Any, max_length: int = MAX_LENGTH) -> str:
    """`msg` (a genpy message, or a plain value) as one short line, e.g. ``vector: {x: 0.5, y: -1.2, z: 0}``."""
    text = _value(msg)
    return text if len(text) <= max_length else text[: max_length - 1] + "…"


def _value(value: Any) -> str:
    slots = getattr(value, "__slots__", None)
    if slots is not None and hasattr(value, "_type"):
        if value._type == "std_msgs/Header":
            return f"{{stamp: {value.stamp.to_sec():.3f}, frame: {value.frame_id or '-'}}}"
        fields = [(name, getattr(value, name)) for name in slots]
        if len(fields) == 1:  # std_msgs/Float64 and the like: just the value
            return _value(fields[0][1])
        return "{" + ", ".join(f"{name}: {_value(field)}" for name, field in fields) + "}"
    if hasattr(value, "to_sec"):  # genpy Time and Duration
        return f"{value.to_sec():.3f}"
    if isinstance(value, bool) or value is None:
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (bytes, bytearray)):
        return f"[{len(value)} bytes]"
    if isinstance(value, (list, tuple)):
        if len(value) > MAX_ITEMS:
            return f"[{len(value)} items]"
        return "[" + ", ".join(_value(item) for item in value) + "]"
    return str(value)
