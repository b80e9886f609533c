"""The Kobuki's event messages, built from the shipped definitions, are the driver's: same type names, md5sums
and wire format, and a rospy subscriber of the real type reads what our class writes."""
from __future__ import annotations

import io

import genmsg
import genmsg.msg_loader
import pytest

from subsumption import kobuki

# md5sums of kobuki_msgs 0.7.0 as the published generated code states them (e.g. rosserial's ros_lib
# kobuki_msgs/BumperEvent.h: getMD5()), i.e. what a running kobuki_node puts in its connection header.
PUBLISHED = {
    "BumperEvent": "ffe360cd50f14f9251d9844083e72ac5",
    "CliffEvent": "c5b106efbb1427a94f517c5e05f06295",
    "WheelDropEvent": "e102837d89384d67669a0df86b63f33b",
}


@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_md5sums_match_the_published_definitions(name):
    cls = getattr(kobuki, name)
    assert cls._type == f"kobuki_msgs/{name}"
    assert cls._md5sum == PUBLISHED[name]
    # ... and genmsg computes the same from the shipped text on its own (not through genpy's class)
    context = genmsg.MsgContext.create_default()
    spec = genmsg.msg_loader.load_msg_from_string(context, kobuki.definition(name), f"kobuki_msgs/{name}")
    assert genmsg.compute_md5(context, spec) == PUBLISHED[name]


def test_a_changed_definition_would_be_caught():
    """The check can fail: one field renamed changes the md5sum."""
    context = genmsg.MsgContext.create_default()
    text = kobuki.definition("BumperEvent").replace("uint8 state\n", "uint8 pressed\n")
    spec = genmsg.msg_loader.load_msg_from_string(context, text, "kobuki_msgs/BumperEvent")
    assert genmsg.compute_md5(context, spec) != PUBLISHED["BumperEvent"]


def test_constants_and_wire_format():
    assert (kobuki.BumperEvent.LEFT, kobuki.BumperEvent.CENTER, kobuki.BumperEvent.RIGHT) == (0, 1, 2)
    assert (kobuki.BumperEvent.RELEASED, kobuki.BumperEvent.PRESSED) == (0, 1)
    assert (kobuki.CliffEvent.FLOOR, kobuki.CliffEvent.CLIFF) == (0, 1)
    assert (kobuki.WheelDropEvent.RAISED, kobuki.WheelDropEvent.DROPPED) == (0, 1)
    buffer = io.BytesIO()
    kobuki.CliffEvent(sensor=2, state=1, bottom=700).serialize(buffer)
    assert buffer.getvalue() == bytes([2, 1]) + (700).to_bytes(2, "little")
    back = kobuki.CliffEvent().deserialize(buffer.getvalue())
    assert (back.sensor, back.state, back.bottom) == (2, 1, 700)


def test_bumper_events_from_bitmask_changes():
    events = kobuki.bumper_events(0, 1 | 4)
    assert [(e.bumper, e.state) for e in events] == [(0, 1), (2, 1)]
    events = kobuki.bumper_events(1 | 4, 2)
    assert [(e.bumper, e.state) for e in events] == [(0, 0), (1, 1), (2, 0)]
    assert kobuki.bumper_events(2, 2) == []


def test_a_node_killed_by_a_signal_leaves_no_temporary_files(tmp_path):
    """Every process that touches a Kobuki topic builds these classes; a node stopped by SIGKILL (a respawn, a
    launch's escalation) runs no exit handler, so building them must leave nothing in the temporary folder."""
    import os
    import signal
    import subprocess
    import sys

    code = "import os, signal, subsumption.kobuki; os.kill(os.getpid(), signal.SIGKILL)"
    done = subprocess.run([sys.executable, "-c", code], env={**os.environ, "TMPDIR": str(tmp_path)}, timeout=60)
    assert done.returncode == -signal.SIGKILL
    assert sorted(p.name for p in tmp_path.iterdir()) == []
