"""rviz with launch/patrol.rviz against the running patrol robot, checked without a person looking: Debian's rviz
in an X server of its own (Xvfb), on a private master.

What is checked: rviz loads the configuration without an error in its log (a display class that does not exist, a
bad property: rviz logs them), it subscribes to exactly the topics its displays name (resolved in the robot's
namespace; a Map display also subscribes to <topic>_updates, every display to /tf and /tf_static), and for each of
those topics that something publishes, rviz holds a live connection to the publisher, and how many bytes it has
received on each (rviz's own statistics): which displays got data. What rviz then draws is in the screenshot, to be
looked at (docs/images/patrol_rviz.png is one).

    .venv/bin/python -m bench.rviz [--level 4] [--sim-seconds 60] [--rate 1] [--out out/rviz]

It starts the master (free port), Xvfb (a free display, which Xvfb picks itself) and `roslaunch subsumption
patrol.launch rviz:=true` (rviz and its helper node rviz_view included), and stops exactly these, by pid. Prints a
row per topic (publishers, rviz connected, bytes received), rviz's log errors, and writes OUT/patrol_rviz.png; exit status 0 when
every published topic reaches rviz and the log has no error. tests/test_rviz.py runs the same checks on a smaller
graph (the simulator alone).
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path

import yaml
from PIL import ImageGrab  # Pillow's X11 grabber (xcb)

from subsumption.ros.launch import launch_env
from subsumption.ros.master import start_master, stop_process, tied_to_parent

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "launch" / "patrol.rviz"
# rviz asks rospack for the package media_export (where other packages' OGRE media would be declared); Debian 12
# does not package it, and rospack says so on rviz's output. Nothing is missing for rviz's own displays.
# Debian's rviz 1.14 on OGRE 1.12 sometimes logs its Map display's shader ("rviz/glsl120/indexed_8bit_image.vert ...
# GLSL link result: active samplers with a different type refer to the same texture image unit": OGRECave/ogre
# issue 1252) under Mesa's software GL; the maps and costmaps are drawn all the same (docs/images/patrol_rviz.png).
KNOWN_NOISE = ("[rospack] Error: no such package media_export", "[librospack]: error while executing command",
               "indexed_8bit_image", "Error prior to using GLSL Program Object")
TOPIC_KEYS = ("Topic", "Marker Topic", "Image Topic")


class VirtualDisplay:
    """An X server of its own (Xvfb) on a display number it picks itself (``-displayfd``: no race with another
    server for a number), in a session of its own; stop() ends exactly that process."""

    def __init__(self, width: int = 1280, height: int = 960) -> None:
        read_end, write_end = os.pipe()
        self.process = subprocess.Popen(
            tied_to_parent(["Xvfb", "-displayfd", str(write_end), "-screen", "0", f"{width}x{height}x24",
                            "-nolisten", "tcp"], "TERM"),
            pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        os.close(write_end)
        number = b""
        while not number.endswith(b"\n"):  # Xvfb writes the number, then a newline: the pipe stays open until then
            chunk = os.read(read_end, 32)
            if not chunk:
                break
            number += chunk
        os.close(read_end)
        if not number.strip():
            self.stop()
            raise RuntimeError(f"Xvfb exited with status {self.process.returncode} before naming its display")
        self.name = ":" + number.decode().strip()

    def screenshot(self, path: Path, box: tuple[int, int, int, int] | None = None) -> Path:
        """The screen (or `box`: left, top, right, bottom) as a PNG at `path` (Pillow reads it over X11)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        ImageGrab.grab(bbox=box, xdisplay=self.name).save(path)
        return path

    def stop(self) -> None:
        """SIGTERM to Xvfb's pid, SIGKILL if it has not gone after 10 s."""
        stop_process(self.process, signal.SIGTERM)


def resolve(topic: str, namespace: str) -> str:
    """`topic` as a node in `namespace` resolves it (rviz's topics in a config are relative or global)."""
    return topic if topic.startswith("/") else "/" + "/".join(p for p in (namespace.strip("/"), topic) if p)


def config_topics(config: Path, namespace: str = "/", sim_time: bool = True) -> set[str]:
    """Every topic rviz subscribes to with `config`, in `namespace`: each enabled display's topic (a Map display's
    also with ``_updates``), /tf and /tf_static (every display's transforms) and, on simulated time, /clock."""
    document = yaml.safe_load(config.read_text())
    topics = {"/tf", "/tf_static"} | ({"/clock"} if sim_time else set())
    for display in document["Visualization Manager"]["Displays"]:
        if not display.get("Enabled", True):
            continue
        for key in TOPIC_KEYS:
            if display.get(key):
                topics.add(resolve(display[key], namespace))
                if display["Class"] == "rviz/Map":
                    topics.add(resolve(display[key], namespace) + "_updates")
    return topics


def window_box(config: Path) -> tuple[int, int, int, int]:
    """Where rviz's window is on a screen without a window manager: the config's Window Geometry."""
    geometry = yaml.safe_load(config.read_text())["Window Geometry"]
    return geometry["X"], geometry["Y"], geometry["X"] + geometry["Width"], geometry["Y"] + geometry["Height"]


def subscriptions(master_uri: str, node: str) -> set[str]:
    """The topics `node` subscribes to, as the master knows them (getSystemState)."""
    _, _, (_, subscribed, _) = xmlrpc.client.ServerProxy(master_uri).getSystemState("/bench_rviz")
    return {topic for topic, nodes in subscribed if node in nodes}


def publishers(master_uri: str) -> dict[str, list[str]]:
    """Each published topic's publishing nodes, as the master knows them."""
    _, _, (published, _, _) = xmlrpc.client.ServerProxy(master_uri).getSystemState("/bench_rviz")
    return {topic: sorted(nodes) for topic, nodes in published}


def connected_inputs(master_uri: str, node: str) -> set[str]:
    """The topics on which `node` has a live inbound connection to a publisher: asked of the node itself
    (its getBusInfo: connection id, peer, direction, transport, topic, connected, ...)."""
    code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/bench_rviz", node)
    if code != 1:
        return set()
    _, _, connections = xmlrpc.client.ServerProxy(uri).getBusInfo("/bench_rviz")
    return {row[4] for row in connections if row[2] == "i" and row[5]}


def received_bytes(master_uri: str, node: str) -> dict[str, int]:
    """Bytes `node` has received so far on each topic it subscribes to, over all its connections (its
    getBusStats: per topic, per connection, its id and the bytes received, then counts): a display that got data."""
    code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/bench_rviz", node)
    if code != 1:
        return {}
    answer = xmlrpc.client.ServerProxy(uri).getBusStats("/bench_rviz")
    stats = answer[2] if isinstance(answer[0], int) else answer  # rospy: code, message, stats; roscpp: the stats
    subscribed = stats[1]  # [publish stats, subscribe stats(, service stats)]
    return {topic: sum(int(connection[1]) for connection in connections) for topic, connections in subscribed}


def log_errors(text: str) -> list[str]:
    """rviz's error lines (ROS ERROR/FATAL, a plugin that failed to load, any 'Error'), the known noise aside."""
    return [line for line in text.splitlines()
            if any(word in line for word in ("ERROR", "FATAL", "Error", "failed to load"))
            and not any(noise in line for noise in KNOWN_NOISE)]


def start_rviz(config: Path, display: VirtualDisplay, env: dict[str, str], log: Path,
               namespace: str = "/") -> subprocess.Popen:
    """rviz with `config` on `display`, node /rviz in `namespace`, software OpenGL (Xvfb has no GPU), its output
    into `log`; in a session of its own, tied to this process."""
    env = dict(env, DISPLAY=display.name, LIBGL_ALWAYS_SOFTWARE="1", ROS_NAMESPACE=namespace)
    with log.open("w") as out:
        return subprocess.Popen(tied_to_parent(["rviz", "-d", str(config), "__name:=rviz"], "TERM"), env=env,
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)


def wait_until(check, timeout: float, step: float = 0.5) -> bool:
    """Poll `check()` until it is true or `timeout` wall seconds have passed (processes coming up)."""
    deadline = time.monotonic() + timeout  # wall clock: processes starting, not ROS time
    while time.monotonic() < deadline:
        if check():
            return True
        time.sleep(step)
    return bool(check())


def ros_time(master_uri: str, env: dict[str, str]) -> float:
    """The graph's /clock now (rostopic, once), or -1 while there is none."""
    try:
        got = subprocess.run(["rostopic", "echo", "-n", "1", "/clock/clock/secs"], env=env, capture_output=True,
                             text=True, timeout=20)
    except subprocess.TimeoutExpired:  # no /clock yet
        return -1.0
    try:
        return float(got.stdout.split()[0])
    except (IndexError, ValueError):
        return -1.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.rviz", description=__doc__.split("\n\n")[0])
    parser.add_argument("--level", type=int, default=4, help="the patrol robot's level (0-5; default 4)")
    parser.add_argument("--sim-seconds", type=float, default=60.0, help="simulated s before the check (default 60)")
    parser.add_argument("--rate", type=float, default=1.0, help="simulated s per wall s (default 1)")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "rviz", help="folder for the screenshot and logs")
    args = parser.parse_args(argv)
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    master = start_master()
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_LOG_DIR=str(out / "ros_logs"),
                          ROS_HOME=str(out / "ros_home")))
    display = VirtualDisplay()
    launched = None
    try:
        with (out / "roslaunch.log").open("w") as log:
            launched = subprocess.Popen(tied_to_parent(
                ["roslaunch", "subsumption", "patrol.launch", f"level:={args.level}", f"rate:={args.rate}",
                 "rviz:=true"]), env=dict(env, DISPLAY=display.name, LIBGL_ALWAYS_SOFTWARE="1"), stdout=log,
                stderr=subprocess.STDOUT, start_new_session=True)
        expected = config_topics(CONFIG)
        print(f"master {master.uri}, display {display.name}; waiting for {args.sim_seconds:.0f} simulated s",
              flush=True)
        if not wait_until(lambda: launched.poll() is not None or ros_time(master.uri, env) >= args.sim_seconds,
                          timeout=600, step=5.0) or launched.poll() is not None:
            print(f"the graph did not reach {args.sim_seconds:.0f} simulated s (roslaunch: {out}/roslaunch.log)")
            return 1
        wait_until(lambda: expected & set(publishers(master.uri)) <= connected_inputs(master.uri, "/rviz"), 30)
        subscribed = subscriptions(master.uri, "/rviz")
        connected = connected_inputs(master.uri, "/rviz")
        received = received_bytes(master.uri, "/rviz")
        published = publishers(master.uri)
        shot = display.screenshot(out / "patrol_rviz.png", window_box(CONFIG))
        rviz_logs = sorted((out / "ros_logs").rglob("rviz-*-stdout.log"))  # roslaunch keeps rviz's output there
        errors = [line for path in rviz_logs for line in log_errors(path.read_text(errors="replace"))]
        if not rviz_logs:
            errors.append(f"no rviz output under {out}/ros_logs (did rviz start?)")
    finally:
        if launched is not None:
            stop_process(launched, signal.SIGINT, 60.0)  # roslaunch stops its ~40 nodes, slow under load
        display.stop()
        master.stop()
    print(f"{'topic':42} {'rviz subscribes':15} {'publishers':30} {'connected':9} bytes received")
    missing = []
    for topic in sorted(expected | subscribed):
        nodes = published.get(topic, [])
        live = topic in connected
        if nodes and not live:
            missing.append(topic)
        print(f"{topic:42} {'yes' if topic in subscribed else 'NO':15} {', '.join(nodes)[:30] or '-':30} "
              f"{'yes' if live else ('NO' if nodes else '-'):9} {received.get(topic, 0)}")
    unexpected = sorted(subscribed ^ expected)
    print(f"rviz log errors: {errors or 'none'}")
    print(f"subscriptions differing from the config's: {unexpected or 'none'}")
    print(f"screenshot: {shot}  ({time.monotonic() - started:.0f} s wall; look at it)")
    return 0 if not missing and not errors and not unexpected else 1


if __name__ == "__main__":
    sys.exit(main())
