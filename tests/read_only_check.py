"""Inside a module group, and in the in-process runtime, every reader of a line gets the very message object
that was published: a module that changed a message it received would change it for every other reader.
:class:`ReadOnlyCheck` is an in-process runtime that checks the convention: after each message has reached all
its readers, its bytes must still be what was published. test_patrol_level4's run uses it (the patrol robot's
levels 0-4, vision included), at the price of serializing each message twice."""
from __future__ import annotations

import io

from subsumption.local import LocalRuntime


def _bytes(msg) -> bytes:
    buffer = io.BytesIO()
    msg.serialize(buffer)
    return buffer.getvalue()


class ReadOnlyCheck(LocalRuntime):
    """Serializes each message as it is published, and again once every reader has had it; the topics whose
    messages a reader changed are in `changed`."""

    changed: list[str] = []
    checked = 0

    def publish(self, topic: str, msg) -> None:
        if not self.topics[topic].subscribers or not hasattr(msg, "serialize"):
            super().publish(topic, msg)
            return
        before = _bytes(msg)
        super().publish(topic, msg)  # one delivery per reader, queued now ...
        self._schedule(self._time, lambda: self._check(topic, msg, before))  # ... and this after all of them

    def _check(self, topic: str, msg, before: bytes) -> None:
        type(self).checked += 1
        if _bytes(msg) != before and topic not in type(self).changed:
            type(self).changed.append(topic)
