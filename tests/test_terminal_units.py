"""The terminal's rules without a network: JSON conversion, protocol checks, control, flood limit, tokens, config.

The live behaviour (a real master, real sockets, roslibpy and a real browser) is in test_terminal_live.py.
"""
from __future__ import annotations

import base64
import json
import re

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import CompressedImage, RegionOfInterest
from std_msgs.msg import Empty

from terminal import protocol
from terminal.config import ConfigError, read_config
from terminal.control import ControlLease, DeadMan, TokenBucket
from terminal.convert import MessageError, dumps, from_json, normalise_type, to_json
from terminal.expose import Exposure
from terminal.hub import clamp_twist, is_motion
from terminal.protocol import ProtocolError
from terminal.security import (TokenError, host_is_local, needs_token, origin_allowed, read_token_file,
                               token_from_header, token_matches)


# ---------------------------------------------------------------------------------------------- convert
def test_messages_convert_as_rosbridge_does():
    image = CompressedImage(format="jpeg", data=b"\xff\xd8\x00\x01")
    image.header.stamp.secs, image.header.stamp.nsecs = 12, 345
    data = to_json(image)
    assert data["header"]["stamp"] == {"secs": 12, "nsecs": 345}
    assert base64.b64decode(data["data"]) == b"\xff\xd8\x00\x01"  # uint8[] as base64, like rosbridge
    grid = OccupancyGrid()
    grid.data = (0, -1, 100)
    assert to_json(grid)["data"] == [0, -1, 100]  # int8[] stays a list
    pose = PoseWithCovarianceStamped()
    pose.pose.covariance = [float("nan")] + [0.0] * 35
    text = dumps(to_json(pose))  # JSON has no NaN: a browser's JSON.parse would refuse it
    assert json.loads(text)["pose"]["covariance"][0] is None
    array = DiagnosticArray(status=[DiagnosticStatus(level=1, name="intruder", values=[KeyValue("x", "1.5")])])
    assert to_json(array)["status"][0]["values"] == [{"key": "x", "value": "1.5"}]


def test_incoming_messages_are_checked_field_by_field():
    twist = from_json(Twist, {"linear": {"x": 0.2}, "angular": {"z": -1}})
    assert (twist.linear.x, twist.angular.z, twist.linear.y) == (0.2, -1.0, 0.0)
    roi = from_json(RegionOfInterest, {"x_offset": 10, "y_offset": 20, "width": 30, "height": 40, "do_rectify": False})
    assert (roi.x_offset, roi.height) == (10, 40)
    assert isinstance(from_json(Empty, {}), Empty)
    for bad, words in [({"linear": {"x": "fast"}}, "linear.x: expected a number"),
                       ({"linear": {"w": 1}}, "has no field 'w'"),
                       ({"linear": 5}, "linear: expected an object"),
                       ({"angular": {"z": True}}, "angular.z: expected a number")]:
        with pytest.raises(MessageError, match=words):
            from_json(Twist, bad, "msg")
    with pytest.raises(MessageError, match="out of range for uint32"):
        from_json(RegionOfInterest, {"x_offset": -1})
    assert normalise_type("geometry_msgs/msg/Twist") == "geometry_msgs/Twist"


# ---------------------------------------------------------------------------------------------- protocol
def test_protocol_accepts_the_ops_roslibpy_sends():
    op = protocol.parse(json.dumps({"op": "subscribe", "id": "subscribe:/map:1", "type": "nav_msgs/OccupancyGrid",
                                    "topic": "/map", "compression": "none", "throttle_rate": 0,
                                    "queue_length": 0}), 1000)
    assert (op.op, op.topic, op.id) == ("subscribe", "/map", "subscribe:/map:1")
    op = protocol.parse('{"op": "publish", "topic": "terminal/cmd_vel", "msg": {"linear": {"x": 1}}}', 1000)
    assert op.fields["msg"] == {"linear": {"x": 1}}
    assert protocol.parse('{"op": "auth", "mac": "abc", "client": "", "t": 0}', 1000).op == "auth"


@pytest.mark.parametrize("frame, words", [
    ("{not json", "malformed JSON"),
    ("NaN", "malformed JSON"),
    ("[1, 2]", "JSON object"),
    ('{"topic": "/x"}', "no \"op\""),
    ('{"op": "launch_missiles", "id": 7}', "unknown op 'launch_missiles'"),
    ('{"op": "advertise_service", "service": "/x"}', "not offered"),
    ('{"op": "subscribe"}', "\"topic\" (a ROS name) is required"),
    ('{"op": "subscribe", "topic": "/a b"}', "not a valid ROS name"),
    ('{"op": "subscribe", "topic": "/x", "throttle_rate": -5}', "throttle_rate"),
    ('{"op": "subscribe", "topic": "/x", "compression": "png"}', "compression"),
    ('{"op": "advertise", "topic": "/x"}', "\"type\" must be"),
    ('{"op": "publish", "topic": "/x", "msg": [1]}', "must be a JSON object"),
    ('{"op": "set_level", "level": "loud"}', "set_level"),
])
def test_protocol_refuses_bad_frames_with_a_reason(frame, words):
    with pytest.raises(ProtocolError) as error:
        protocol.parse(frame, 10000)
    assert words in error.value.text


def test_oversize_frames_are_refused_before_parsing():
    with pytest.raises(ProtocolError, match="2001 bytes dropped: the limit is 2000"):
        protocol.parse("x" * 2001, 2000)


def test_status_replies_and_levels():
    reply = json.loads(protocol.status("error", "bad", "id7"))
    assert reply == {"op": "status", "level": "error", "msg": "bad", "id": "id7"}
    assert protocol.level_allows("error", "error") and not protocol.level_allows("error", "info")
    assert protocol.level_allows("info", "warning") and not protocol.level_allows("none", "error")
    text = protocol.publish_text("/t", dumps({"a": 1}))
    assert json.loads(text) == {"op": "publish", "topic": "/t", "msg": {"a": 1}}


# ---------------------------------------------------------------------------------------------- control
def test_one_operator_at_a_time():
    lease = ControlLease()
    assert lease.acquire(1, "10.0.0.1", 0.0) is None
    assert lease.acquire(1, "10.0.0.1", 1.0) is None  # again: still the holder
    refusal = lease.acquire(2, "10.0.0.2", 5.0)
    assert refusal and "held by operator client 1 (10.0.0.1)" in refusal and "you may watch" in refusal
    assert not lease.release(2, 6.0)
    assert lease.release(1, 6.0)
    assert lease.acquire(2, "10.0.0.2", 7.0) is None
    assert lease.held_s(8.0) == pytest.approx(7.0)


def test_dead_man_fires_once_after_silence_while_moving():
    switch = DeadMan(0.25)
    switch.command(moving=True, now=0.0)
    assert not switch.due(0.2)
    assert switch.due(0.3) and not switch.due(0.4)  # once
    switch.command(moving=False, now=1.0)
    assert not switch.due(5.0)  # stopped by the operator: nothing to do
    switch.command(moving=True, now=6.0)
    assert switch.cut() and not switch.cut()  # a disconnect stops it at once, once
    assert switch.stops == 2
    with pytest.raises(ValueError):
        DeadMan(0.0)


def test_token_bucket_limits_a_flood():
    bucket = TokenBucket(rate=100, burst=10, now=0.0)
    assert sum(bucket.allow(0.0) for _ in range(50)) == 10  # the burst
    allowed = sum(bucket.allow(i / 1000) for i in range(1, 1001))  # 1000 a second for 1 s
    assert 95 <= allowed <= 105


def test_twist_clamped_to_limits():
    twist = Twist()
    twist.linear.x, twist.angular.z = 5.0, -9.0
    clamp_twist(twist, 0.3, 1.0)
    assert (twist.linear.x, twist.angular.z) == (0.3, -1.0)
    assert is_motion(twist) and not is_motion(Twist())


# ---------------------------------------------------------------------------------------------- security
def test_token_rules(tmp_path):
    assert not needs_token("127.0.0.1", "") and needs_token("0.0.0.0", "") and needs_token("127.0.0.1", "f")
    assert token_matches("s3cret-token", "s3cret-token") and not token_matches("s3cret-tokeN", "s3cret-token")
    assert not token_matches(None, "s3cret-token") and not token_matches("", "s3cret-token")
    assert token_from_header("Bearer abc") == "abc" and token_from_header("token abc") == "abc"
    assert token_from_header("Basic abc") is None
    path = tmp_path / "token"
    path.write_text("  abcdefgh12345\nsecond line\n")
    assert read_token_file(str(path)) == "abcdefgh12345"
    path.write_text("short")
    with pytest.raises(TokenError, match=f"token file {path}: the token"):
        read_token_file(str(path))
    with pytest.raises(TokenError, match="cannot read it"):
        read_token_file(str(tmp_path / "missing"))


def test_host_and_origin_checks():
    assert host_is_local("127.0.0.1:9090", 9090) and host_is_local("localhost:9090", 9090)
    assert not host_is_local("evil.example:9090", 9090) and not host_is_local(None, 9090)
    assert origin_allowed(None, "127.0.0.1:9090", ())  # roslibpy sends no Origin
    assert origin_allowed("http://127.0.0.1:9090", "127.0.0.1:9090", ())
    assert not origin_allowed("http://evil.example", "127.0.0.1:9090", ())
    assert origin_allowed("http://dash.example", "127.0.0.1:9090", ("http://dash.example",))


# ---------------------------------------------------------------------------------------------- config
def test_config_reads_parameters_and_options():
    params = {"port": 0, "cmd_vel_topic": "operator/cmd_vel", "arbiters": "a, b"}
    config = read_config(lambda name, default: params.get(name, default), ["--host", "0.0.0.0"])
    assert (config.host, config.port, config.arbiters) == ("0.0.0.0", 0, ("a", "b"))
    assert config.topic("cmd_vel") == "operator/cmd_vel" and config.topic("camera") == "camera/rgb/image_raw/compressed"
    assert config.topic("map") == "/map"
    assert config.expose == ()  # by default only the terminal's own topics
    exposed = read_config(lambda name, default: {"expose": "all"}.get(name, default), ["--expose", "/tf,scan"])
    assert exposed.expose == ("/tf", "scan")  # the option wins over the parameter
    assert read_config(lambda name, default: {"expose": ["/odom"]}.get(name, default), []).expose == ("/odom",)
    exposure = Exposure.of(read_config(lambda name, default: default, ["--expose", "all"]).expose, str)
    assert exposure.everything and exposure.allows("/anything")
    listed = Exposure.of(("/tf", "scan"), lambda name: "/robot1/" + name if name[0] != "/" else name)
    assert listed.allows("/robot1/scan") and listed.allows("/tf") and not listed.allows("/scan")
    assert not Exposure.of((), str)


@pytest.mark.parametrize("params, words", [
    ({"port": "abc"}, "~port must be an integer 0..65535, got 'abc'"),
    ({"port": 70000}, "~port must be an integer"),
    ({"deadman_timeout": 0.05}, "~drive_period"),
    ({"max_rate": -1}, "~max_rate"),
    ({"camera_topic": ""}, "~camera_topic must be a topic name"),
    ({"arbiters": 5}, "~arbiters must be a list"),
    ({"expose": "all, /tf"}, "~expose: 'all' already exposes every topic"),
    ({"expose": "/tf, 9bad"}, "~expose: '9bad' is not a topic name"),
    ({"expose": 3}, "~expose must be 'all' or a list of topic names"),
])
def test_config_errors_name_the_parameter(params, words):
    with pytest.raises(ConfigError, match=words.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        read_config(lambda name, default: params.get(name, default), [])


# ---------------------------------------------------------------------------------------------- operator script
def test_operator_scripts_are_checked(tmp_path):
    from terminal.operator import ScriptError, read_script

    path = tmp_path / "script.yaml"
    path.write_text("- {at: 2, release: true}\n- {at: 1, drive: [0.2, 0], for: 1.5}\n- {at: 0, select: [1, 2, 3, 4]}\n")
    steps = read_script(path)
    assert [step.action for step in steps] == ["select", "drive", "release"] and steps[1].duration == 1.5
    for text, words in [("{at: 1}", "a list of steps"), ("- {select: [1, 2, 3, 4]}", "step 1: needs 'at'"),
                        ("- {at: 1, select: [1, 2]}", "step 1: select is [x, y, width, height]"),
                        ("- {at: 1, drive: [0.2, 0]}", "step 1: drive needs a duration"),
                        ("- {at: 1, release: true, stop: 1}", "exactly one of"),
                        ("- {at: 1, after: 2, release: true}", "step 1: needs 'at'"),
                        ("- {at: 1, select: 'not a name'}", "or the name of a finder"),
                        ("- {at: 1, select: face, within: 0}", "within (seconds a finder may look) must be > 0")]:
        path.write_text(text)
        with pytest.raises(ScriptError, match=re.escape(f"{path}: ") + ".*" + re.escape(words)):
            read_script(path)
    # 'after' steps keep the file's order and count from the end of the step before; a finder looks 'within'
    path.write_text("- {at: 5, select: face, within: 60}\n- {after: 10, drive: [0, 0.6], for: 3}\n"
                    "- {after: 2, release: true}\n")
    steps = read_script(path)
    assert [(s.action, s.at, s.relative, s.duration) for s in steps] == [
        ("select", 5.0, False, 60.0), ("drive", 10.0, True, 3.0), ("release", 2.0, True, 0.0)]


def test_a_bad_network_file_is_a_config_error_naming_it(tmp_path):
    from terminal.network_view import load_view

    with pytest.raises(ConfigError, match="~network: .*missing.yaml"):
        load_view(str(tmp_path / "missing.yaml"), None)
    view = load_view("terminal/examples/operator_demo.yaml", None)
    assert [a.name for a in view.arbiters] == ["suppressor_cruise_cmd_vel", "inhibitor_cruise_cmd_vel"]
    assert view.svg.startswith("<svg") and "<title>arbiter__suppressor_cruise_cmd_vel</title>" in view.svg


def test_camera_frames_reach_clients_as_jpeg_whatever_came_in():
    import cv2
    import numpy as np

    from subsumption import images
    from terminal.ros_side import camera_encoder

    encode = camera_encoder(quality=80)
    rgb = np.zeros((48, 64, 3), np.uint8)
    rgb[:, :32] = (255, 0, 0)
    raw = images.from_array(rgb, "rgb8")
    raw.header.stamp.secs = 7
    ok, png = cv2.imencode(".png", rgb[:, :, ::-1])
    for msg in (raw, CompressedImage(format="png", data=png.tobytes()), images.compressed_jpeg(rgb)):
        encoded = encode(msg)
        decoded = cv2.imdecode(np.frombuffer(encoded.jpeg, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1]
        assert decoded.shape == (48, 64, 3) and decoded[10, 5, 0] > 200 and decoded[10, 60, 0] < 50
        sent = json.loads(encoded.msg_json)
        assert base64.b64decode(sent["data"]) == encoded.jpeg and encoded.source is msg
    assert encode(raw).stamp == 7.0


def test_a_server_that_cannot_listen_closes_its_loop_before_it_reports():
    """A terminal on a port in use prints one line and exits 1; its event loop was left for the garbage collector,
    which at exit sometimes found its file descriptors gone and printed a traceback after that line."""
    import socket

    from terminal.hub import Hub
    from terminal.server import WebServer

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        config = read_config(lambda name, default: {"port": busy.getsockname()[1]}.get(name, default), [])
        server = WebServer(config, Hub(config, [], {}, lambda name: name, None), None, None, "/", "/terminal")
        with pytest.raises(OSError):
            server.start()
        server._thread.join(timeout=5)
    assert server.loop is not None and server.loop.is_closed()
