"""The operator terminal on a real ROS graph, with real clients: roslibpy, raw WebSockets, HTTP, and Debian's
chromium driven by Playwright.

One world for the whole file (starting ROS nodes and a browser is the slow part): a private master; the
example network ``terminal/examples/operator_demo.yaml`` launched with roslaunch (the robot's own motor line,
``cruise``, with the terminal on top through a suppressor and an inhibitor: real arbiter nodes); the synthetic
scene publishing camera frames, a map, tf, goals, a plan, a target and alarms, and recording what reaches
ROS; and a second terminal that needs a token. The tests judge what arrived where, never how fast (the
timing goals are in bench/terminal).
"""
from __future__ import annotations

import asyncio
import base64
import concurrent.futures
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import aiohttp
import cv2
import numpy as np
import pytest

from conftest import ROOT, ProcessGroup, ros_env
from subsumption.network import load
from subsumption.ros.launch import launch
from subsumption.ros.master import start_master
from terminal.scene import read_records

DEADLINE = 20.0
CAMERA = "/camera/rgb/image_raw/compressed"
TOKEN = "test-token-0123456789"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def wait_for(condition, what: str, deadline: float = DEADLINE):
    """Poll `condition` (wall clock: these are real processes) until it returns something true."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


class World:
    def __init__(self, env: dict, log_dir: Path) -> None:
        self.env = env
        self.log_dir = log_dir
        self.record = log_dir / "record.jsonl"
        self.record.touch()
        self.processes = ProcessGroup(env, log_dir)
        self.launched = None
        self.launch_log = log_dir / "launch.log"
        self.port = 0
        self.locked_port = 0

    def records(self, topic: str, since: float = 0.0) -> list[dict]:
        """What the scene's recorder heard on `topic` from `since` (wall clock) on."""
        return read_records(self.record, topic, since)

    def launch_output(self) -> str:
        return self.launch_log.read_text()


def _printed_port(text: str, line: str = "rosbridge") -> int | None:
    match = re.search(rf"^{line}: ws://127\.0\.0\.1:(\d+)$", text, re.M)
    return int(match.group(1)) if match else None


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    log_dir = tmp_path_factory.mktemp("terminal_world")
    master = start_master()
    env = ros_env(master.uri)
    world = World(env, log_dir)
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    world.bad = start_bad_settings(env, busy.getsockname()[1])
    try:
        # the example network, with the terminal on a free port and a short send timeout for the abuse test
        text = (ROOT / "terminal/examples/operator_demo.yaml").read_text()
        settings = (f"          port: 0\n          send_timeout: 1.0\n          send_buffer: 16384\n"
                    f"          url_file: {log_dir / 'urls.json'}\n          expose: /tf, /cmd_vel\n")
        text = text.replace("        params:\n", "        params:\n" + settings, 1)
        network_file = log_dir / "operator_demo.yaml"
        network_file.write_text(text)
        with world.launch_log.open("w") as log:
            world.launched = launch(load(network_file), xml=log_dir / "operator_demo.launch", env=env,
                                    stdout=log, stderr=subprocess.STDOUT)
        world.processes.start([sys.executable, "-m", "terminal.scene", "--rate", "15", "--alarm-period", "2",
                               "--record", str(world.record)])
        token_file = log_dir / "token"
        token_file.write_text(TOKEN + "\n")
        world.locked = world.processes.start([sys.executable, str(ROOT / "nodes/terminal"), "__name:=locked",
                                              "__ns:=locked", "_port:=0", f"_token_file:={token_file}",
                                              "--expose", "all"])
        world.port = wait_for(lambda: _printed_port(world.launch_output()), "the terminal's rosbridge line",
                              deadline=40)
        world.locked_port = wait_for(lambda: _printed_port(world.locked.log.read_text()), "the locked terminal")
        wait_for(lambda: world.records("/cmd_vel"), "the robot's own motor line (cruise -> arbiters -> cmd_vel)")
        yield world
    finally:  # everything is told to stop first, then waited for: the shutdowns overlap
        busy.close()
        if world.launched is not None and world.launched.running():
            world.launched.process.send_signal(signal.SIGINT)  # roslaunch stops its nodes, as on Ctrl-C
        for process in world.bad:
            if process.poll() is None:
                process.terminate()
        world.processes.stop_all()
        for process in world.bad:
            process.wait(timeout=10)
        if world.launched is not None:
            world.launched.stop()
        master.stop()


# ------------------------------------------------------------------------------------------------ helpers
async def connect(port: int, headers: dict | None = None, origin: str | None = None):
    session = aiohttp.ClientSession()
    try:
        ws = await session.ws_connect(f"ws://127.0.0.1:{port}/", headers=headers, origin=origin, max_msg_size=0)
    except BaseException:
        await session.close()
        raise
    return session, ws


async def next_reply(ws, op: str = "status", topic: str | None = None, timeout: float = DEADLINE) -> dict:
    """The next message of kind `op` (and `topic`), skipping others (camera frames keep coming)."""
    end = time.monotonic() + timeout
    while True:
        message = await ws.receive(timeout=max(0.1, end - time.monotonic()))
        if message.type != aiohttp.WSMsgType.TEXT:
            raise AssertionError(f"connection ended while waiting for {op}: {message.type} {message.extra}")
        data = json.loads(message.data)
        if data.get("op") == op and (topic is None or data.get("topic") == topic):
            return data


def run(coroutine):
    """asyncio.run, also after the browser tests: Playwright's sync API keeps a loop running in this thread, so
    the coroutine then runs in a thread of its own."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return asyncio.run(coroutine)
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, coroutine).result()


# ------------------------------------------------------------------------------------------------ start-up
def test_prints_its_urls_each_on_a_line(world):
    text = world.launch_output()
    assert f"terminal: http://127.0.0.1:{world.port}/\n" in text
    assert f"rosbridge: ws://127.0.0.1:{world.port}\n" in text
    urls = json.loads((world.log_dir / "urls.json").read_text())  # ~url_file: the same, for programs
    assert urls == {"terminal": f"http://127.0.0.1:{world.port}/", "rosbridge": f"ws://127.0.0.1:{world.port}",
                    "host": "127.0.0.1", "port": world.port, "token": None}
    locked = world.locked.log.read_text()
    assert f"terminal: http://127.0.0.1:{world.locked_port}/?token={TOKEN}\n" in locked  # the token is needed


BAD_SETTINGS = [(["_port:=abc"], 2, "~port must be an integer 0..65535, got 'abc'"),
                (["_port:=BUSY"], 1, "cannot listen on 127.0.0.1:")]


def start_bad_settings(env: dict, busy_port: int) -> list[subprocess.Popen]:
    """Terminals that must refuse to start (started with the world: their start-up is the slow part), and one
    on a public address, which must print a generated token."""
    started = [subprocess.Popen([sys.executable, str(ROOT / "nodes/terminal"), f"__name:=bad{i}",
                                 *(a.replace("BUSY", str(busy_port)) for a in args)],
                                env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True) for i, (args, _, _) in enumerate(BAD_SETTINGS)]
    started.append(subprocess.Popen([sys.executable, str(ROOT / "nodes/terminal"), "__name:=public", "__ns:=public",
                                     "--host", "0.0.0.0", "--port", "0"], env=env, stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, text=True, start_new_session=True))
    return started


def test_bad_settings_are_one_line_errors(world):
    *refused, public = world.bad
    for process, (args, status, words) in zip(refused, BAD_SETTINGS):
        out, err = process.communicate(timeout=DEADLINE)
        assert process.returncode == status, (args, err)
        assert words in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
        assert "terminal: http" not in out
    # any address but loopback: a token is generated and printed in the URL, as Jupyter does
    first = public.stdout.readline()
    assert re.fullmatch(r"terminal: http://[^/\s]+:\d+/\?token=[0-9a-f]{48}\n", first), first
    assert re.fullmatch(r"rosbridge: ws://[^/\s]+:\d+\n", public.stdout.readline())
    public.terminate()


# ------------------------------------------------------------------------------------------------ roslibpy
def test_roslibpy_subscribes_and_publishes(world):
    import roslibpy

    ros = roslibpy.Ros("127.0.0.1", world.port)
    ros.run()
    try:
        got: dict[str, list] = {"camera": [], "map": [], "pose": [], "alarms": []}
        for key, topic, kind in [("camera", CAMERA, "sensor_msgs/CompressedImage"),
                                 ("map", "/map", "nav_msgs/OccupancyGrid"),
                                 ("pose", "terminal/robot_pose", "geometry_msgs/PoseStamped"),
                                 ("alarms", "alarm", "diagnostic_msgs/DiagnosticArray")]:
            roslibpy.Topic(ros, topic, kind).subscribe(got[key].append)
        wait_for(lambda: all(got.values()), "camera, map, robot pose (from tf) and an alarm through roslibpy")
        frame = cv2.imdecode(np.frombuffer(base64.b64decode(got["camera"][-1]["data"]), np.uint8), cv2.IMREAD_COLOR)
        assert frame is not None and frame.shape == (240, 320, 3)
        grid = got["map"][0]
        assert len(grid["data"]) == grid["info"]["width"] * grid["info"]["height"] and 100 in grid["data"]
        assert got["pose"][-1]["header"]["frame_id"] == "map"

        since = time.time()
        command = roslibpy.Topic(ros, "terminal/cmd_vel", "geometry_msgs/Twist")
        command.publish(roslibpy.Message({"linear": {"x": 0.123}, "angular": {"z": 0.5}}))
        sent = wait_for(lambda: world.records("/terminal/cmd_vel", since), "the command on /terminal/cmd_vel")
        assert sent[0]["msg"]["linear"]["x"] == pytest.approx(0.123)
        # ... and the suppressor hands it to the robot's motor line in place of cruise's 0.2 m/s
        wait_for(lambda: any(r["msg"]["linear"]["x"] == pytest.approx(0.123) for r in world.records("/cmd_vel", since)),
                 "the operator's command on /cmd_vel, through the suppressor")
        roslibpy.Topic(ros, "terminal/release", "std_msgs/Empty").publish(roslibpy.Message({}))
        wait_for(lambda: world.records("/terminal/release", since), "the release on /terminal/release")
    finally:
        ros.close()


def test_roslibpy_with_the_token_in_a_header(world):
    import roslibpy

    ros = roslibpy.Ros("127.0.0.1", world.locked_port, headers={"Authorization": f"Bearer {TOKEN}"})
    ros.run()
    try:
        got: list = []
        roslibpy.Topic(ros, "terminal/status", "diagnostic_msgs/DiagnosticStatus").subscribe(got.append)
        status = wait_for(lambda: got, "the locked terminal's status")[-1]
        assert status["name"] == "/locked/locked"
    finally:
        ros.close()


def test_scripted_operator_speaks_the_same_protocol(world, tmp_path):
    from terminal.operator import Operator, read_script

    script = tmp_path / "script.yaml"
    script.write_text("- {at: 0.0, select: [10, 20, 30, 40]}\n- {at: 0.1, drive: [0.15, 0.0], for: 0.3}\n"
                      "- {at: 0.6, release: true}\n")
    since = time.time()
    operator = Operator("127.0.0.1", world.port)
    try:
        result = operator.run(read_script(script)).as_json()
    finally:
        operator.close()
    assert result["operator_commands"] >= 5 and not result["refusals"]
    assert 0.4 <= result["manual_control_s"] <= 5.0
    target = wait_for(lambda: world.records("/terminal/target", since), "the scripted target")[0]["msg"]
    assert (target["x_offset"], target["y_offset"], target["width"], target["height"]) == (10, 20, 30, 40)
    drives = wait_for(lambda: world.records("/terminal/release", since) and world.records("/terminal/cmd_vel", since),
                      "the scripted drive and release")
    assert drives[0]["msg"]["linear"]["x"] == pytest.approx(0.15) and drives[-1]["msg"]["linear"]["x"] == 0
    # handing control back clears the operator's target: a zero-size box follows the selected one
    cleared = wait_for(lambda: len(world.records("/terminal/target", since)) >= 2, "the target cleared on release")
    assert cleared and world.records("/terminal/target", since)[-1]["msg"]["width"] == 0


# ------------------------------------------------------------------------------------------------ refusals
def test_only_the_command_topics_can_be_published(world):
    async def scenario():
        session, ws = await connect(world.port)
        try:
            await ws.send_json({"op": "publish", "id": "p1", "topic": "/map", "msg": {}})
            reply = await next_reply(ws)
            assert reply["level"] == "error" and reply["id"] == "p1" and "cannot be published" in reply["msg"]
            await ws.send_json({"op": "advertise", "topic": "/rosout", "type": "rosgraph_msgs/Log"})
            assert "cannot be published" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "subscribe", "topic": "/rosout"})
            assert "not exposed by this terminal" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "advertise", "topic": "terminal/cmd_vel", "type": "geometry_msgs/TwistStamped"})
            assert "carries geometry_msgs/Twist, not geometry_msgs/TwistStamped" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "publish", "topic": "terminal/cmd_vel", "msg": {"linear": {"x": "fast"}}})
            assert "linear.x: expected a number" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "call_service", "id": "c1", "service": "/rosapi/set_param",
                                "args": {"name": "/x", "value": "1"}})
            answer = await next_reply(ws, "service_response")
            assert answer["result"] is False and answer["id"] == "c1"  # rosapi's read-only subset only
        finally:
            await session.close()

    since = time.time()
    run(scenario())
    assert not world.records("/terminal/cmd_vel", since)  # nothing bad reached ROS


def test_rosapi_subset_lists_what_foxglove_can_subscribe(world):
    """Foxglove's and Lichtblick's rosbridge connection starts with rosapi's topics_and_raw_types (and nodes): the
    terminal answers them itself, listing the topics a client may subscribe to here, with their definitions."""
    async def scenario():
        session, ws = await connect(world.port)
        try:
            await ws.send_json({"op": "call_service", "id": "t", "service": "/rosapi/topics_and_raw_types"})
            topics = await next_reply(ws, "service_response")
            await ws.send_json({"op": "call_service", "id": "n", "service": "/rosapi/nodes"})
            nodes = await next_reply(ws, "service_response")
            await ws.send_json({"op": "call_service", "id": "y", "service": "/rosapi/topic_type",
                                "args": {"topic": "/map"}})
            topic_type = await next_reply(ws, "service_response")
            await ws.send_json({"op": "call_service", "id": "b", "service": "/rosapi/topic_type", "args": {}})
            bad = await next_reply(ws, "service_response")
            return topics, nodes, topic_type, bad
        finally:
            await session.close()

    topics, nodes, topic_type, bad = run(scenario())
    assert topics["result"] is True and topics["id"] == "t"
    listed = dict(zip(topics["values"]["topics"], topics["values"]["types"]))
    assert listed["/map"] == "nav_msgs/OccupancyGrid" and len(listed) >= 10
    definitions = dict(zip(topics["values"]["topics"], topics["values"]["typedefs_full_text"]))
    assert "\nHeader header" in definitions["/map"] and "MSG: nav_msgs/MapMetaData" in definitions["/map"]
    assert any(name.endswith("/terminal") for name in nodes["values"]["nodes"])
    assert topic_type["values"] == {"type": "nav_msgs/OccupancyGrid"}
    assert bad["result"] is False and "args must be" in bad["values"]


async def rosapi_topics(ws, op_id: str = "t") -> dict[str, str]:
    await ws.send_json({"op": "call_service", "id": op_id, "service": "/rosapi/topics"})
    values = (await next_reply(ws, "service_response"))["values"]
    return dict(zip(values["topics"], values["types"]))


def test_listed_graph_topics_are_exposed_read_only(world):
    """~expose: /tf, /cmd_vel (a parameter, in the network file): those two are served and listed beside the
    terminal's own topics, nothing else of the graph; publishing to them is refused."""
    async def scenario():
        session, ws = await connect(world.port)
        try:
            listed = await rosapi_topics(ws)
            assert listed["/tf"] == "tf2_msgs/TFMessage" and listed["/cmd_vel"] == "geometry_msgs/Twist"
            assert "/map" in listed and "/rosout" not in listed
            await ws.send_json({"op": "subscribe", "id": "s", "topic": "/tf"})
            tf = await next_reply(ws, "publish", "/tf")
            assert {"map", "base_link"} <= {t["header"]["frame_id"] for t in tf["msg"]["transforms"]} | {
                t["child_frame_id"] for t in tf["msg"]["transforms"]}
            await ws.send_json({"op": "subscribe", "topic": "/rosout"})
            assert "not exposed by this terminal" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "publish", "id": "p", "topic": "/cmd_vel", "msg": {"linear": {"x": 1.0}}})
            refused = await next_reply(ws)
            assert refused["id"] == "p" and "exposed read-only by this terminal (subscribe only)" in refused["msg"]
            await ws.send_json({"op": "advertise", "topic": "/tf", "type": "tf2_msgs/TFMessage"})
            assert "exposed read-only" in (await next_reply(ws))["msg"]
        finally:
            await session.close()

    run(scenario())


def _subscribers(world, topic: str) -> list[str]:
    import rosgraph
    state = rosgraph.Master("/test_expose", master_uri=world.env["ROS_MASTER_URI"]).getSystemState()
    return next((nodes for name, nodes in state[1] if name == topic), [])


def test_expose_all_serves_any_topic_after_the_token_and_only_while_watched(world):
    """--expose all on the locked terminal: the token first, then any topic of the graph (here /cmd_vel, the robot's
    motor line) is listed and served; the terminal subscribes to it only while a client watches it."""
    async def scenario():
        session, ws = await connect(world.locked_port)
        try:
            await ws.send_json({"op": "subscribe", "topic": "/cmd_vel"})
            assert "authentication required" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "call_service", "service": "/rosapi/topics"})
            assert "authentication required" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "auth", "mac": TOKEN})
            listed = await rosapi_topics(ws)
            assert {"/rosout", "/tf", "/cmd_vel", "/terminal/cmd_vel", "/locked/terminal/status"} <= set(listed)
            assert listed["/rosout"] == "rosgraph_msgs/Log"
            assert "/locked/locked" not in _subscribers(world, "/cmd_vel")
            await ws.send_json({"op": "subscribe", "id": "c", "topic": "/cmd_vel", "type": "geometry_msgs/Twist"})
            twist = await next_reply(ws, "publish", "/cmd_vel")
            assert isinstance(twist["msg"]["linear"]["x"], float)  # the robot's motor line, as rosbridge sends it
            assert "/locked/locked" in _subscribers(world, "/cmd_vel")
            await ws.send_json({"op": "publish", "topic": "/cmd_vel", "msg": {}})
            assert "exposed read-only" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "subscribe", "topic": "/cmd_vel", "type": "std_msgs/Empty"})
            assert "carries geometry_msgs/Twist, not std_msgs/Empty" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "unsubscribe", "id": "c", "topic": "/cmd_vel"})
            wait_for(lambda: "/locked/locked" not in _subscribers(world, "/cmd_vel"), "the exposed topic unsubscribed")
        finally:
            await session.close()

    run(scenario())


def test_one_operator_at_a_time_and_release(world):
    async def scenario():
        session_a, a = await connect(world.port)
        session_b, b = await connect(world.port)
        try:
            await a.send_json({"op": "set_level", "level": "info"})
            await a.send_json({"op": "publish", "topic": "terminal/cmd_vel", "msg": {}})
            assert (await next_reply(a))["msg"] == "you hold control"
            await b.send_json({"op": "publish", "id": "b1", "topic": "terminal/target", "msg": {"width": 5}})
            refusal = await next_reply(b)
            assert refusal["level"] == "error" and "refused: control is held by operator client" in refusal["msg"]
            await b.send_json({"op": "subscribe", "topic": CAMERA})  # a viewer may still watch
            assert (await next_reply(b, "publish", CAMERA))["msg"]["format"]
            await a.send_json({"op": "publish", "topic": "terminal/release", "msg": {}})
            await b.send_json({"op": "set_level", "level": "info"})
            await b.send_json({"op": "advertise", "topic": "terminal/target", "type": "sensor_msgs/RegionOfInterest"})
            assert (await next_reply(b))["msg"] == "you hold control"
        finally:
            await session_a.close()
            await session_b.close()

    since = time.time()
    run(scenario())
    assert not world.records("/terminal/target", since)  # the refused target never went out


def test_dead_man_switch_stops_the_robot(world):
    """A driving client that falls silent, and one that disconnects: both end with a zero Twist."""
    async def drive_then(ending: str) -> None:
        session, ws = await connect(world.port)
        try:
            for _ in range(5):
                await ws.send_json({"op": "publish", "topic": "terminal/cmd_vel", "msg": {"linear": {"x": 0.25}}})
                await asyncio.sleep(0.05)
            if ending == "silence":
                await asyncio.sleep(1.0)  # connected, but nothing comes: a frozen tab, a dead link
        finally:
            await session.close()

    for ending in ("silence", "disconnect"):
        since = time.time()
        run(drive_then(ending))

        def stopped(since=since):
            commands = world.records("/terminal/cmd_vel", since)
            moving = [c for c in commands if c["msg"]["linear"]["x"] != 0]
            return moving and any(c["t"] > moving[-1]["t"] and c["msg"]["linear"]["x"] == 0 for c in commands)

        wait_for(stopped, f"a zero Twist after the driving client's {ending}")


# ------------------------------------------------------------------------------------------------ abuse
def test_malformed_oversize_and_binary_frames_get_errors_and_the_connection_lives(world):
    async def scenario():
        session, ws = await connect(world.port)
        try:
            for frame, words in [("{oops", "malformed JSON"), ('{"op": "explode"}', "unknown op"),
                                 ('{"op": "publish", "topic": "terminal/cmd_vel", "msg": {"linear": {"x": NaN}}}',
                                  "malformed JSON"),
                                 (json.dumps({"op": "publish", "topic": "terminal/target",
                                              "msg": {"pad": "x" * 100000}}),
                                  "the limit is 16384 bytes")]:
                await ws.send_str(frame)
                assert words in (await next_reply(ws))["msg"]
            await ws.send_bytes(b"\x00\x01")
            assert "binary frame dropped" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "subscribe", "topic": "terminal/status"})  # still answered
            assert (await next_reply(ws, "publish", "terminal/status"))["msg"]["name"] == "/terminal"
        finally:
            await session.close()
        session, ws = await connect(world.port)  # over 1 MiB is never buffered: that connection closes (1009)
        try:
            await ws.send_str("x" * (2 << 20))
            while (message := await ws.receive(timeout=DEADLINE)).type == aiohttp.WSMsgType.TEXT:
                pass
            assert message.type in (aiohttp.WSMsgType.CLOSE, aiohttp.WSMsgType.CLOSED)
            # the code the server's close frame carries; ws.close_code reads 1006 instead when the server drops the
            # socket before the client's closing handshake is through (seen once in a full suite)
            code = message.data if message.type == aiohttp.WSMsgType.CLOSE else ws.close_code
            assert code == 1009
        finally:
            await session.close()

    run(scenario())


def test_flood_is_limited_and_the_robot_keeps_its_levels(world):
    """1,000 messages a second for 1 s (bench/terminal floods for 10 s): the excess is dropped with an error,
    the connection lives, at most the rate limit reaches ROS, and the robot's own motor line is not disturbed."""
    async def scenario() -> tuple[int, list, float, float]:
        session, ws = await connect(world.port)
        replies: list = []

        async def read():
            async for message in ws:
                replies.append(json.loads(message.data))

        reader = asyncio.get_running_loop().create_task(read())
        try:
            start = time.time()
            sent = 0
            while time.time() - start < 1.0:
                for _ in range(10):
                    await ws.send_str('{"op": "publish", "topic": "/map", "msg": {}}')  # refused, cheap
                    sent += 1
                await asyncio.sleep(0.01)
            end = time.time()
            await ws.send_json({"op": "subscribe", "topic": "terminal/status"})
            await asyncio.sleep(0.5)
            return sent, replies, start, end
        finally:
            reader.cancel()
            await session.close()

    sent, replies, start, end = run(scenario())
    assert sent >= 700
    floods = [r for r in replies if r.get("op") == "status" and r["msg"].startswith("flood:")]
    assert floods and "the limit is 100 messages a second" in floods[0]["msg"]
    assert len(floods) <= 3  # one notice a second, not one per dropped message
    assert any(r.get("op") == "publish" and r.get("topic") == "terminal/status" for r in replies)  # still served
    cruise = [r for r in world.records("/cmd_vel", start) if r["t"] <= end]
    assert len(cruise) >= 5 and all(r["msg"]["linear"]["x"] == pytest.approx(0.2) for r in cruise)

    async def command_flood() -> float:
        session, ws = await connect(world.port)
        try:
            begin = time.time()
            while time.time() - begin < 1.0:
                for _ in range(10):
                    await ws.send_str('{"op": "publish", "topic": "terminal/cmd_vel", "msg": {}}')
                await asyncio.sleep(0.01)
            return begin
        finally:
            await session.close()

    begin = run(command_flood())
    time.sleep(0.5)
    published = len(world.records("/terminal/cmd_vel", begin))
    assert 100 <= published <= 200 + 100 * 1.5  # the burst, then 100 a second


def _masked_text_frame(text: str) -> bytes:
    payload = text.encode()
    mask = os.urandom(4)
    header = bytes([0x81, 0x80 | 126]) + len(payload).to_bytes(2, "big") if len(payload) > 125 else \
        bytes([0x81, 0x80 | len(payload)])
    return header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload))


def test_a_client_that_never_reads_is_closed_and_others_are_served(world):
    stalled = socket.socket()
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    stalled.connect(("127.0.0.1", world.port))
    try:
        key = base64.b64encode(os.urandom(16)).decode()
        stalled.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{world.port}\r\nUpgrade: websocket\r\n"
                        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                        "Sec-WebSocket-Version: 13\r\n\r\n".encode())
        assert stalled.recv(12) == b"HTTP/1.1 101"
        for topic in (CAMERA, "/map"):
            stalled.sendall(_masked_text_frame(json.dumps({"op": "subscribe", "topic": topic})))
        # ... and never read again

        async def watch() -> int:
            session, ws = await connect(world.port)
            try:
                await ws.send_json({"op": "subscribe", "topic": CAMERA})
                frames = 0
                end = time.monotonic() + 1.0
                while time.monotonic() < end:
                    await next_reply(ws, "publish", CAMERA)
                    frames += 1
                return frames
            finally:
                await session.close()

        assert run(watch()) >= 5  # 15 frames a second keep coming to a client that reads
        wait_for(lambda: "took no data for 1.0 s: closing it" in world.launch_output(),
                 "the terminal closing the client that never reads")
    finally:
        stalled.close()


# ------------------------------------------------------------------------------------------------ HTTP
def test_mjpeg_stream_like_web_video_server(world):
    async def scenario():
        async with aiohttp.ClientSession() as session:
            url = f"http://127.0.0.1:{world.port}"
            async with session.get(f"{url}/stream?topic=/camera/rgb/image_raw") as response:
                assert response.status == 200
                assert response.headers["Content-Type"].startswith("multipart/x-mixed-replace;boundary=")
                reader = aiohttp.MultipartReader.from_response(response)
                frames = []
                for _ in range(2):
                    part = await reader.next()
                    frames.append(await part.read())
            for jpeg in frames:
                assert cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR).shape == (240, 320, 3)
            assert frames[0] != frames[1]
            async with session.get(f"{url}/snapshot?topic={CAMERA}") as response:
                assert response.status == 200 and response.content_type == "image/jpeg"
            async with session.get(f"{url}/stream?topic=/elsewhere") as response:
                assert response.status == 404 and CAMERA in await response.text()

    run(scenario())


def test_token_is_checked_on_every_request(world):
    async def scenario():
        url = f"http://127.0.0.1:{world.locked_port}"
        async with aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True)) as session:  # keeps IP cookies
            for path in ("/", "/config.json", "/static/terminal.js", f"/stream?topic={CAMERA}"):
                async with session.get(url + path) as response:
                    assert response.status == 403 and "needs a token" in await response.text()
            async with session.get(url + "/config.json?token=wrong-token-000") as response:
                assert response.status == 403 and "Wrong token" in await response.text()
            async with session.get(url + "/config.json", headers={"Authorization": f"Bearer {TOKEN}"}) as response:
                assert response.status == 200
            async with session.get(f"{url}/?token={TOKEN}", allow_redirects=False) as response:
                assert response.status == 302 and response.headers["Location"] == "/"  # the token becomes a cookie
            async with session.get(url + "/config.json") as response:
                assert response.status == 200  # the cookie
        # WebSocket: nothing before auth; a wrong token closes; the right one opens the topics
        session, ws = await connect(world.locked_port)
        try:
            await ws.send_json({"op": "subscribe", "topic": "terminal/status"})
            assert "authentication required" in (await next_reply(ws))["msg"]
            await ws.send_json({"op": "auth", "mac": TOKEN, "client": "", "dest": "", "rand": "", "t": 0,
                                "level": "", "end": 0})
            await ws.send_json({"op": "subscribe", "topic": "terminal/status"})
            assert (await next_reply(ws, "publish"))["topic"] == "terminal/status"
        finally:
            await session.close()
        session, ws = await connect(world.locked_port)
        try:
            await ws.send_json({"op": "auth", "mac": "wrong-token-000"})
            assert "authentication failed" in (await next_reply(ws))["msg"]
            closing = await ws.receive(timeout=DEADLINE)
            assert closing.type in (aiohttp.WSMsgType.CLOSE, aiohttp.WSMsgType.CLOSED, aiohttp.WSMsgType.CLOSING)
        finally:
            await session.close()
        with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
            await connect(world.locked_port, headers={"Authorization": "Bearer wrong-token-000"})
        assert refused.value.status == 403

    run(scenario())


def test_without_a_token_only_local_hosts_and_own_origin(world):
    async def scenario():
        async with aiohttp.ClientSession() as session:
            async with session.get(f"http://127.0.0.1:{world.port}/", headers={"Host": "evil.example"}) as response:
                assert response.status == 403 and "is not this machine" in await response.text()
        with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
            await connect(world.port, origin="http://evil.example")
        assert refused.value.status == 403
        session, ws = await connect(world.port, origin=f"http://127.0.0.1:{world.port}")
        await session.close()

    run(scenario())


# ------------------------------------------------------------------------------------------------ browser
@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        try:
            yield chromium
        finally:
            chromium.close()


def wait_js(page, expression: str, what: str):
    """Poll a JavaScript expression in the page. (Playwright's wait_for_function evaluates a string, which the
    page's Content-Security-Policy rightly forbids; evaluate() is not subject to it.)"""
    return wait_for(lambda: page.evaluate(expression), what)


def _camera_pixels(page) -> str:
    return page.evaluate("document.getElementById('camera').toDataURL('image/png')")


def test_page_shows_video_map_network_and_alarms(world, browser, tmp_path):
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    try:
        page.goto(f"http://127.0.0.1:{world.port}/")
        wait_js(page, "window.terminalStats && window.terminalStats.drawn >= 2", "two frames drawn")
        first = _camera_pixels(page)
        wait_js(page, f"window.terminalStats.drawn >= {page.evaluate('window.terminalStats.drawn') + 3}",
                "three more frames")
        assert _camera_pixels(page) != first  # the canvas changes: frames arrive
        page.wait_for_selector("#network svg g.node", timeout=DEADLINE * 1000)
        assert page.locator("#arbiters tr").count() == 2
        page.wait_for_selector("#alarms-log li", timeout=DEADLINE * 1000)
        assert "intruder" in page.locator("#alarms-log").inner_text()
        assert page.locator("#connection").inner_text() == "connected"
        page.screenshot(path=str(tmp_path / "terminal.png"))
        assert not errors, errors
    finally:
        page.close()


def test_page_box_and_enter_publish_the_target(world, browser):
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    try:
        page.goto(f"http://127.0.0.1:{world.port}/")
        wait_js(page, "window.terminalStats.drawn >= 1", "a frame drawn")
        box = page.locator("#camera").bounding_box()
        since = time.time()
        page.mouse.move(box["x"] + box["width"] * 0.25, box["y"] + box["height"] * 0.25)
        page.mouse.down()
        page.mouse.move(box["x"] + box["width"] * 0.75, box["y"] + box["height"] * 0.5, steps=4)
        page.mouse.up()
        assert not world.records("/terminal/target", since)  # nothing before Enter
        page.keyboard.press("Enter")
        target = wait_for(lambda: world.records("/terminal/target", since), "the manual target")[0]["msg"]
        # the box in image pixels (320x240), whatever size the canvas is drawn at
        assert target["x_offset"] == pytest.approx(80, abs=3) and target["y_offset"] == pytest.approx(60, abs=3)
        assert target["width"] == pytest.approx(160, abs=3) and target["height"] == pytest.approx(60, abs=3)
        page.keyboard.press("r")  # release
        wait_for(lambda: world.records("/terminal/release", since), "the release")
    finally:
        page.close()


def test_page_drives_while_a_key_is_held_and_stops_on_release(world, browser):
    page = browser.new_page()
    try:
        page.goto(f"http://127.0.0.1:{world.port}/")
        page.wait_for_selector("#network svg g.node", timeout=DEADLINE * 1000)
        wait_js(page, "document.getElementById('connection').textContent === 'connected'", "connected")
        since = time.time()
        page.keyboard.down("ArrowUp")
        moving = wait_for(lambda: [r for r in world.records("/terminal/cmd_vel", since) if r["msg"]["linear"]["x"] > 0]
                          if len(world.records("/terminal/cmd_vel", since)) >= 5 else None, "commands while held")
        assert moving[0]["msg"]["linear"]["x"] == pytest.approx(0.3)
        # the suppressor's upper line holds the motor line: the page lights it
        page.wait_for_selector("#network g.node.lit", timeout=DEADLINE * 1000)
        assert page.locator("#arbiter-suppressor_cruise_cmd_vel.lit").count() == 1
        released = time.time()
        page.keyboard.up("ArrowUp")
        stop = wait_for(lambda: [r for r in world.records("/terminal/cmd_vel", released)
                                 if r["msg"]["linear"]["x"] == 0], "a zero Twist on release")[0]
        time.sleep(0.5)
        later = [r for r in world.records("/terminal/cmd_vel", stop["t"]) if r["msg"]["linear"]["x"] != 0]
        assert not later  # nothing after the stop: the robot stays stopped until the suppressor lets go
        page.wait_for_selector("#network g.node.lit", state="detached", timeout=DEADLINE * 1000)  # unlit
        # the on-screen pad (a phone has no arrow keys): held while the pointer is down
        since = time.time()
        page.hover("#pad .left")
        page.mouse.down()
        wait_for(lambda: any(r["msg"]["angular"]["z"] > 0 for r in world.records("/terminal/cmd_vel", since)),
                 "a turn while the pad's left button is held")
        lifted = time.time()
        page.mouse.up()
        wait_for(lambda: any(r["msg"]["angular"]["z"] == 0 for r in world.records("/terminal/cmd_vel", lifted)),
                 "a zero Twist when the pad is let go")
        # Space: stop, through the inhibitor, until pressed again
        since = time.time()
        page.keyboard.press("Space")
        wait_for(lambda: len(world.records("/terminal/stop", since)) >= 3, "stop sent while stop is on")
        page.wait_for_selector("#arbiter-inhibitor_cruise_cmd_vel.lit", timeout=DEADLINE * 1000)
        page.keyboard.press("Space")
        page.wait_for_selector("#arbiter-inhibitor_cruise_cmd_vel.lit", state="detached", timeout=DEADLINE * 1000)
    finally:
        page.close()


ROSLIBJS = Path(sys.executable).parent.parent / "share/roslibjs/roslib.min.js"  # put there by `make setup` (npm)


@pytest.mark.skipif(not ROSLIBJS.exists(), reason=f"roslibjs not installed ({ROSLIBJS}: `make setup` needs npm)")
def test_roslibjs_subscribes_and_publishes(world, browser):
    """roslibjs 1.4.1 itself (npm), in the browser: the terminal speaks the protocol it speaks."""
    context = browser.new_context(bypass_csp=True)  # roslibjs is added inline, which the page's CSP forbids
    page = context.new_page()
    try:
        page.goto(f"http://127.0.0.1:{world.port}/config.json")  # the terminal's origin, not its page
        page.add_script_tag(path=str(ROSLIBJS))
        page.evaluate("""() => {
            window.heard = [];
            const ros = new ROSLIB.Ros({url: `ws://${location.host}`});
            new ROSLIB.Topic({ros, name: '/map', messageType: 'nav_msgs/OccupancyGrid'})
                .subscribe((grid) => window.heard.push(grid.info.width));
            window.command = new ROSLIB.Topic({ros, name: '/terminal/cmd_vel', messageType: 'geometry_msgs/Twist'});
        }""")
        assert wait_js(page, "window.heard.length > 0", "the map through roslibjs") is True
        since = time.time()
        page.evaluate("window.command.publish(new ROSLIB.Message({linear: {x: 0.05, y: 0, z: 0}, "
                      "angular: {x: 0, y: 0, z: 0}}))")
        sent = wait_for(lambda: world.records("/terminal/cmd_vel", since), "roslibjs's command on ROS")
        assert sent[0]["msg"]["linear"]["x"] == pytest.approx(0.05)
    finally:
        context.close()


def test_page_needs_the_token_on_a_locked_terminal(world, browser):
    page = browser.new_page()
    try:
        response = page.goto(f"http://127.0.0.1:{world.locked_port}/")
        assert response.status == 403 and "needs a token" in page.content()
        page.goto(f"http://127.0.0.1:{world.locked_port}/?token=wrong-token-000")
        assert "Wrong token" in page.content()
        page.goto(f"http://127.0.0.1:{world.locked_port}/?token={TOKEN}")
        assert page.url == f"http://127.0.0.1:{world.locked_port}/"  # the token left the address bar
        wait_js(page, "document.getElementById('connection').textContent === 'connected'", "connected")
    finally:
        page.close()


def test_the_terminal_records_every_command_of_any_client(world):
    """Issue 31: after 55 commands from a browser-like client metrics.json said operator_commands 0 (only the
    scripted operator counted). The terminal now counts on its own side, whoever the client is, and keeps the
    time under manual control (ROS time, from the command that takes control to the release), on ~status."""
    async def record(ws) -> dict:
        await ws.send_json({"op": "subscribe", "topic": "terminal/status"})
        values = {kv["key"]: kv["value"] for kv in (await next_reply(ws, "publish", "terminal/status"))["msg"]["values"]}
        await ws.send_json({"op": "unsubscribe", "topic": "terminal/status"})
        return values

    async def scenario() -> tuple[dict, dict]:
        session, ws = await connect(world.port)
        try:
            before = await record(ws)
            for _ in range(20):
                await ws.send_json({"op": "publish", "topic": "terminal/cmd_vel", "msg": {}})
                await asyncio.sleep(0.05)
            await ws.send_json({"op": "publish", "topic": "terminal/release", "msg": {}})
            await asyncio.sleep(0.5)
            after = await record(ws)
            end = time.monotonic() + DEADLINE  # the status comes once a second; on a loaded machine later
            while (int(after["operator_commands"]) - int(before["operator_commands"]) < 21
                   or after["operator"] != "") and time.monotonic() < end:
                await asyncio.sleep(0.5)
                after = await record(ws)
            return before, after
        finally:
            await session.close()

    before, after = run(scenario())
    assert int(after["operator_commands"]) - int(before["operator_commands"]) >= 21, (before, after)
    assert float(after["manual_control_s"]) - float(before["manual_control_s"]) >= 0.5, (before, after)
    assert after["operator"] == ""  # released
