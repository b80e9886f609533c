"""The read-only part of rosbridge's rosapi that Foxglove and Lichtblick call on connecting, answered by the
terminal itself: ``/rosapi/topics``, ``/rosapi/topics_and_raw_types``, ``/rosapi/topic_type`` and
``/rosapi/nodes``. Without them Foxglove's rosbridge connection lists nothing (``getTopics`` failed).

The topics listed are the ones a client can subscribe to here: the terminal's channels and, with ``--expose``,
the graph's topics it serves read-only (all the master knows a publisher of, or the listed ones); a list of the
whole graph without them would offer topics that the terminal then refuses. ``nodes`` are the master's. No service changes anything:
commands stay the operator's four topics, under the token rules of every other op.
"""
from __future__ import annotations

from typing import Any, Callable

import roslib.message

SERVICES = ("/rosapi/topics", "/rosapi/topics_and_raw_types", "/rosapi/topic_type", "/rosapi/nodes")


class RosapiError(ValueError):
    """A call that cannot be answered (a bad argument); the text says why."""


def full_text(msg_type: str) -> str:
    """The message definition with its dependencies, as ``gendeps --cat`` and rosapi give it."""
    msg_class = roslib.message.get_message_class(msg_type)
    if msg_class is None:
        raise RosapiError(f"unknown message type {msg_type!r}")
    return msg_class._full_text


def answer(service: str, args: Any, topics: dict[str, str], node_names: Callable[[], list[str]]) -> dict[str, Any]:
    """The values of rosapi's response to `service` called with `args`, given the served `topics` (name -> type)
    and a way to ask the master for the nodes."""
    names = sorted(topics)
    if service == "/rosapi/topics":
        return {"topics": names, "types": [topics[name] for name in names]}
    if service == "/rosapi/topics_and_raw_types":
        return {"topics": names, "types": [topics[name] for name in names],
                "typedefs_full_text": [full_text(topics[name]) for name in names]}
    if service == "/rosapi/topic_type":
        topic = args.get("topic") if isinstance(args, dict) else None
        if not isinstance(topic, str):
            raise RosapiError("/rosapi/topic_type: args must be {\"topic\": NAME}")
        return {"type": topics.get(topic, "")}  # rosapi answers "" for a topic it does not know
    if service == "/rosapi/nodes":
        return {"nodes": sorted(node_names())}
    raise RosapiError(f"service {service} is not offered by this terminal")
