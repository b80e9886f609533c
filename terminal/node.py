"""``rosrun subsumption terminal``: the operator terminal as a ROS node.

rospy owns the main thread (``rospy.spin``), each subscription has its thread, and the web server runs its
asyncio loop on one more. Real time and real sockets only: the terminal cannot run in the in-process
``LocalRuntime`` (simulated clock, no network); it joins a ROS graph. On start it prints, each on its own
line::

    terminal: http://127.0.0.1:9090/
    rosbridge: ws://127.0.0.1:9090

(with ``?token=...`` in the first when a token is needed). A bad parameter or an address that cannot be
used is one line on stderr and exit status 2 or 1.
"""
from __future__ import annotations

import json
import logging
import os
import socket
import sys
from pathlib import Path

import rosnode
import rospy

from subsumption.ros.runtime import start_node

from .config import Config, ConfigError, parse_args, read_config
from .expose import Exposure
from .hub import Channel, Hub
from .network_view import NetworkView, load_view
from .security import TokenError, generate_token, needs_token, read_token_file
from .topics import ROLES, arbiter_role


class _RospyHandler(logging.Handler):
    """The hub's and server's log lines go where a ROS user looks: rosout and the node's log."""

    def emit(self, record: logging.LogRecord) -> None:
        text = self.format(record)
        if record.levelno >= logging.ERROR:
            rospy.logerr(text)
        elif record.levelno >= logging.WARNING:
            rospy.logwarn(text)
        else:
            rospy.loginfo(text)


def build_channels(config: Config, view: NetworkView | None, resolve) -> tuple[list[Channel], dict]:
    """Every exposed topic as a channel, and the command topics (role -> (Role, resolved name))."""
    channels = [Channel(role, resolve(config.topic(role.role))) for role in ROLES]
    names = list(config.arbiters) + [a.name for a in view.arbiters] if view else list(config.arbiters)
    known = {channel.name for channel in channels}
    for arbiter in dict.fromkeys(names):
        role = arbiter_role(arbiter)
        name = resolve(role.default)
        if name not in known:
            channels.append(Channel(role, name))
            known.add(name)
    commands = {role.role: (role, resolve(config.topic(role.role))) for role in ROLES if role.command}
    return channels, commands


def display_host(host: str) -> str:
    """The address to print: this machine's name for a wildcard address; IPv6 in brackets."""
    if host in ("0.0.0.0", "::", ""):
        host = socket.gethostname()
    return f"[{host}]" if ":" in host else host


def write_url_file(path: str, urls: dict) -> None:
    """The URLs as JSON, written whole (a reader polling for the file never sees half of it)."""
    target = Path(path)
    partial = target.with_name(target.name + ".partial")
    partial.write_text(json.dumps(urls) + "\n")
    os.chmod(partial, 0o600)  # it may hold the token
    partial.replace(target)


def main(argv: list[str] | None = None) -> int:
    """Run ``rosrun subsumption terminal`` until shutdown; exit status 2 on bad options."""
    from .ros_side import RosSide
    from .server import WebServer

    argv = list(sys.argv if argv is None else argv)
    args = rospy.myargv(argv)[1:]
    parse_args(args)  # --help and bad options answer before any ROS
    start_node("terminal", argv=argv)  # its frame buffers, too, go back to the system
    name = rospy.get_name()
    logger = logging.getLogger("terminal")
    logger.addHandler(_RospyHandler())
    logger.setLevel(logging.INFO)
    logger.propagate = False
    try:
        config = read_config(lambda key, default: rospy.get_param("~" + key, default), args)
        token = None
        if needs_token(config.host, config.token_file):
            token = read_token_file(config.token_file) if config.token_file else generate_token()
        view = load_view(config.network, config.level) if config.network else None
    except (ConfigError, TokenError) as error:
        print(f"{name}: error: {error}", file=sys.stderr, flush=True)
        return 2
    channels, commands = build_channels(config, view, rospy.resolve_name)
    hub = Hub(config, channels, commands, rospy.resolve_name, token)
    hub.exposure = Exposure.of(config.expose, rospy.resolve_name)
    ros = RosSide(config, hub, {role: config.topic(role) for role in commands})
    hub.sink = ros
    hub.node_names = rosnode.get_node_names
    server = WebServer(config, hub, view, token, rospy.get_namespace(), name)
    try:
        port = server.start()
    except OSError as error:
        print(f"{name}: error: cannot listen on {config.host}:{config.port}: {error.strerror or error}",
              file=sys.stderr, flush=True)
        return 1
    ros.start()
    host = display_host(config.host)
    query = f"?token={token}" if token else ""
    if config.url_file:  # before the lines: a program that saw them finds the file
        write_url_file(config.url_file, {"terminal": f"http://{host}:{port}/{query}",
                                         "rosbridge": f"ws://{host}:{port}", "host": host, "port": port,
                                         "token": token})
    print(f"terminal: http://{host}:{port}/{query}", flush=True)
    print(f"rosbridge: ws://{host}:{port}", flush=True)
    rospy.loginfo("%s: serving %d topics (%d commands), graph topics exposed read-only: %s, network %s, %s", name,
                  len(channels), len(commands), hub.exposure.describe(), view.name if view else "none",
                  "token required" if token else "no token (loopback)")
    rospy.spin()
    ros.stop()
    server.stop()
    return 0
