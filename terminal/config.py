"""The terminal's settings: private ROS parameters (``~name``), a few also as command-line options.

Command-line options win over parameters, parameters over defaults. Every value is checked; a bad one raises
:class:`ConfigError` naming the parameter, and the node exits with that one line.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from typing import Any, Callable

from .expose import ExposeError, parse_expose
from .topics import ROLES

GetParam = Callable[[str, Any], Any]


class ConfigError(ValueError):
    """A parameter with a bad value; the text names it."""


@dataclass
class Config:
    host: str = "127.0.0.1"
    port: int = 9090
    token_file: str = ""
    url_file: str = ""                  # also write the URLs (and token) here as JSON, for programs that start it
    allowed_origins: tuple[str, ...] = ()
    network: str = ""                   # network file to draw; "" draws none
    level: int | None = None            # its levels 0..level (default: all)
    arbiters: tuple[str, ...] = ()      # arbiter names to watch besides the network's
    expose: tuple[str, ...] = ()        # graph topics served read-only besides the terminal's: ("all",) or names
    topics: dict[str, str] = field(default_factory=dict)  # role -> topic name as configured
    max_message_bytes: int = 16384      # a larger frame gets an error reply and is dropped
    max_frame_bytes: int = 1 << 20      # a larger frame closes the connection (1009): never buffered
    max_rate: float = 100.0             # messages a second per client, on average ...
    burst: int = 200                    # ... and at once
    send_timeout: float = 5.0           # a client whose socket takes no data for this long is closed
    send_buffer: int = 131072           # kernel send buffer per WebSocket (bytes; 0: the kernel's autotuning)
    auth_timeout: float = 10.0          # seconds to authenticate on a WebSocket before it is closed
    max_clients: int = 32
    deadman_timeout: float = 0.25       # no motor command for this long while moving: stop
    max_linear: float = 0.3             # m/s; the page drives at it, commands are clamped to it
    max_angular: float = 1.0            # rad/s
    drive_period: float = 0.05          # s between motor commands while a key is held (page)
    map_frame: str = "map"
    base_frame: str = "base_link"
    use_tf: bool = True
    pose_rate: float = 10.0             # Hz of terminal/robot_pose
    jpeg_quality: int = 80              # for raw camera images

    def topic(self, role: str) -> str:
        """The topic of a role (cmd_vel, camera, map, ...) after the parameters' renaming."""
        return self.topics[role]


def _number(name: str, value: Any, low: float, high: float = math.inf, integer: bool = False) -> Any:
    bad = isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not isinstance(value, int))
    if bad or not (low <= value <= high):
        kind = "an integer" if integer else "a number"
        bounds = f"{low:g}..{high:g}" if high != math.inf else f">= {low:g}"
        raise ConfigError(f"~{name} must be {kind} {bounds}, got {value!r}")
    return int(value) if integer else float(value)


def _text(name: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ConfigError(f"~{name} must be a string, got {value!r}")
    return value


def _names(name: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [part for part in value.replace(",", " ").split() if part]
    if not isinstance(value, (list, tuple)) or not all(isinstance(item, str) for item in value):
        raise ConfigError(f"~{name} must be a list of strings, got {value!r}")
    return tuple(value)


def _expose(value: Any) -> tuple[str, ...]:
    try:
        return parse_expose(value)
    except ExposeError as error:
        raise ConfigError(str(error)) from None


def parse_args(argv: list[str]) -> argparse.Namespace:
    """The terminal node's command-line options (ROS parameters work too)."""
    parser = argparse.ArgumentParser(prog="terminal", description="The remote operator terminal: a web page and "
                                     "a rosbridge v2 WebSocket on one port. ROS parameters (~host, ~port, "
                                     "~token_file, ~network, ~level, ~expose, ~<role>_topic, ...) work too; see "
                                     "docs/terminal.md.")
    parser.add_argument("--host", help="address to listen on (default 127.0.0.1; any other needs a token)")
    parser.add_argument("--port", type=int, help="port of the page and the WebSocket (default 9090; 0: any free)")
    parser.add_argument("--token-file", help="read the token from this file (also required on 127.0.0.1 then)")
    parser.add_argument("--network", help="network file to draw (the robot's subsumption network)")
    parser.add_argument("--level", type=int, help="draw levels 0..LEVEL of it")
    parser.add_argument("--expose", metavar="all|TOPIC,TOPIC", help="also serve topics of the ROS graph, read-only "
                        "(subscribe only; /tf included): 'all' of them or a comma-separated list (parameter ~expose; "
                        "default: only the terminal's own topics)")
    return parser.parse_args(argv)


def read_config(get_param: GetParam, argv: list[str] | None = None) -> Config:
    """The settings from ~parameters (`get_param(name, default)`) and command-line options `argv`."""
    args = parse_args(argv or [])
    default = Config()

    def param(name: str) -> Any:
        return get_param(name, getattr(default, name))

    config = Config(
        host=_text("host", args.host if args.host is not None else param("host")),
        port=_number("port", args.port if args.port is not None else param("port"), 0, 65535, integer=True),
        token_file=_text("token_file", args.token_file if args.token_file is not None else param("token_file")),
        url_file=_text("url_file", param("url_file")),
        allowed_origins=_names("allowed_origins", param("allowed_origins")),
        network=_text("network", args.network if args.network is not None else param("network")),
        arbiters=_names("arbiters", param("arbiters")),
        expose=_expose(args.expose if args.expose is not None else param("expose")),
        max_message_bytes=_number("max_message_bytes", param("max_message_bytes"), 256, 1 << 20, integer=True),
        max_rate=_number("max_rate", param("max_rate"), 1, 100000),
        burst=_number("burst", param("burst"), 1, 100000, integer=True),
        send_timeout=_number("send_timeout", param("send_timeout"), 0.1, 3600),
        send_buffer=_number("send_buffer", param("send_buffer"), 0, 1 << 26, integer=True),
        auth_timeout=_number("auth_timeout", param("auth_timeout"), 0.1, 3600),
        max_clients=_number("max_clients", param("max_clients"), 1, 10000, integer=True),
        deadman_timeout=_number("deadman_timeout", param("deadman_timeout"), 0.02, 10),
        max_linear=_number("max_linear", param("max_linear"), 0, 100),
        max_angular=_number("max_angular", param("max_angular"), 0, 100),
        drive_period=_number("drive_period", param("drive_period"), 0.01, 1),
        map_frame=_text("map_frame", param("map_frame")),
        base_frame=_text("base_frame", param("base_frame")),
        use_tf=bool(param("use_tf")),
        pose_rate=_number("pose_rate", param("pose_rate"), 0.1, 100),
        jpeg_quality=_number("jpeg_quality", param("jpeg_quality"), 1, 100, integer=True),
    )
    level = args.level if args.level is not None else get_param("level", None)
    if level is not None and level != "":
        config.level = _number("level", level, 0, 1000, integer=True)
    if config.drive_period * 2 > config.deadman_timeout:
        raise ConfigError(f"~drive_period ({config.drive_period:g} s) must be at most half of ~deadman_timeout "
                          f"({config.deadman_timeout:g} s), or the dead-man switch fires while a key is held")
    for role in ROLES:
        name = get_param(role.param.lstrip("~"), role.default)
        if not isinstance(name, str) or not name.strip("/"):
            raise ConfigError(f"{role.param} must be a topic name, got {name!r}")
        config.topics[role.role] = name
    return config
