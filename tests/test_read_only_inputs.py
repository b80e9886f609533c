"""Inside a module group, and in the in-process runtime, every reader of a line gets the very message object
that was published: a module that changed a message it received would change it for every other reader. This
checks the convention on the patrol robot's levels 0-4 (vision included) in the in-process runtime: after each
message has reached all its readers, its bytes are still what was published."""
from __future__ import annotations

import io

import pytest
from test_patrol_level4 import _short_scene

import experiments.runner
from experiments.patrol import PatrolRun, execute
from subsim import world_path
from subsumption.local import LocalRuntime


def _bytes(msg) -> bytes:
    buffer = io.BytesIO()
    msg.serialize(buffer)
    return buffer.getvalue()


class ReadOnlyCheck(LocalRuntime):
    """Serializes each message as it is published, and again once every reader has had it."""

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


@pytest.mark.timeout(300)
def test_no_module_of_the_patrol_robot_changes_a_message_it_received(tmp_path, monkeypatch):
    monkeypatch.setattr(experiments.runner, "LocalRuntime", ReadOnlyCheck)
    world, goals = _short_scene(tmp_path)
    execute(PatrolRun(4, world, tmp_path / "out", 6.0, seed=1, runtime="local", goals_file=goals,
                      map_yaml=(world_path("pingpong").parent / "pingpong.yaml"), progress=False))
    assert ReadOnlyCheck.checked > 1000
    assert ReadOnlyCheck.changed == [], f"messages changed by a reader on {ReadOnlyCheck.changed}"
