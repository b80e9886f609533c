"""A scripted operator: what a person does at the terminal's page, done by a program through the same protocol.

It connects to the terminal's rosbridge WebSocket with roslibpy, exactly as any rosbridge client would, and
publishes on the terminal's command topics. A script is a YAML list of steps, each at a time in seconds after
the start (divided by ``--time-scale``, so a script written in simulated seconds fits a simulation running
at that many times real time)::

    - {at: 5.0, select: [120, 60, 80, 160]}        # drag a box (x, y, width, height in image pixels), Enter
    - {at: 12.0, drive: [0.2, 0.0], for: 2.0}      # hold a drive key: linear m/s, angular rad/s
    - {at: 15.0, stop: 1.0}                        # hold stop (the inhibitor) for 1 s
    - {at: 20.0, release: true}                    # hand control back

    python -m terminal.operator SCRIPT --port 9090 [--host H] [--token T] [--time-scale 3]

It prints one JSON line: ``operator_commands`` (messages published), ``manual_control_s`` (from the first
command to the release, in script seconds), ``released_at_s`` and any refusals the terminal sent.
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ACTIONS = ("select", "drive", "stop", "release")


class ScriptError(ValueError):
    """A script step that cannot be run; the message names the file and the step."""


@dataclass
class Step:
    at: float
    action: str
    value: Any
    duration: float = 0.0


@dataclass
class Result:
    operator_commands: int = 0
    first_command_s: float | None = None
    released_at_s: float | None = None
    refusals: list[str] = field(default_factory=list)

    def as_json(self) -> dict[str, Any]:
        manual = None
        if self.first_command_s is not None:
            manual = (self.released_at_s if self.released_at_s is not None else self.first_command_s) - \
                self.first_command_s
        return {"operator_commands": self.operator_commands, "manual_control_s": manual,
                "released_at_s": self.released_at_s, "refusals": self.refusals}


def read_script(path: str | Path) -> list[Step]:
    """The steps of a script file, checked, in time order."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ScriptError(f"{path}: cannot read the script ({error})") from None
    if not isinstance(data, list):
        raise ScriptError(f"{path}: a script is a list of steps like {{at: 5.0, select: [x, y, w, h]}}")
    steps = []
    for index, item in enumerate(data, 1):
        where = f"{path}: step {index}"
        if not isinstance(item, dict) or not isinstance(item.get("at"), (int, float)) or item["at"] < 0:
            raise ScriptError(f"{where}: needs 'at' (seconds >= 0)")
        actions = [key for key in item if key in ACTIONS]
        if len(actions) != 1:
            raise ScriptError(f"{where}: needs exactly one of {', '.join(ACTIONS)}")
        action = actions[0]
        value = item[action]
        if action == "select" and not (isinstance(value, list) and len(value) == 4
                                       and all(isinstance(v, int) and v >= 0 for v in value)):
            raise ScriptError(f"{where}: select is [x, y, width, height], whole pixels >= 0")
        if action == "drive" and not (isinstance(value, list) and len(value) == 2
                                      and all(isinstance(v, (int, float)) for v in value)):
            raise ScriptError(f"{where}: drive is [linear m/s, angular rad/s]")
        duration = item.get("for", value if action == "stop" else 0.0)
        if action in ("drive", "stop") and (not isinstance(duration, (int, float)) or duration <= 0):
            raise ScriptError(f"{where}: {action} needs a duration > 0 ('for: SECONDS', or 'stop: SECONDS')")
        steps.append(Step(float(item["at"]), action, value, float(duration)))
    return sorted(steps, key=lambda step: step.at)


class Operator:
    """The terminal's commands through roslibpy; every method blocks for the time the action takes."""

    def __init__(self, host: str, port: int, token: str | None = None, prefix: str = "terminal/",
                 period: float = 0.05) -> None:
        import roslibpy

        self._roslibpy = roslibpy
        headers = {"Authorization": f"Bearer {token}"} if token else None
        self.ros = roslibpy.Ros(host, port, headers=headers)
        self.ros.run()
        self.period = period
        self.result = Result()
        self._start = time.monotonic()
        self._scale = 1.0
        self._lock = threading.Lock()
        proto = self.ros.factory._proto  # roslibpy 2.1 has no handler for status ops; refusals arrive as them
        if proto is not None:
            proto._message_handlers["status"] = self._on_status
        self.topics = {name: roslibpy.Topic(self.ros, prefix + name, kind) for name, kind in (
            ("cmd_vel", "geometry_msgs/Twist"), ("target", "sensor_msgs/RegionOfInterest"),
            ("stop", "std_msgs/Empty"), ("release", "std_msgs/Empty"))}

    def _on_status(self, message: dict) -> None:
        if message.get("level") == "error":
            with self._lock:
                self.result.refusals.append(str(message.get("msg", "")))

    def _now(self) -> float:
        return (time.monotonic() - self._start) * self._scale

    def _publish(self, name: str, msg: dict) -> None:
        self.topics[name].publish(self._roslibpy.Message(msg))
        self.result.operator_commands += 1
        if self.result.first_command_s is None:
            self.result.first_command_s = self._now()

    def select(self, x: int, y: int, width: int, height: int) -> None:
        self._publish("target", {"x_offset": x, "y_offset": y, "width": width, "height": height,
                                 "do_rectify": False})

    def drive(self, linear: float, angular: float, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self._publish("cmd_vel", {"linear": {"x": linear}, "angular": {"z": angular}})
            time.sleep(self.period)
        self._publish("cmd_vel", {})  # the key let go: stop

    def stop(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self._publish("stop", {})
            time.sleep(0.1)

    def release(self) -> None:
        self._publish("release", {})
        self.result.released_at_s = self._now()

    def run(self, steps: list[Step], time_scale: float = 1.0) -> Result:
        """Play the steps at their times (script seconds / time_scale of wall time)."""
        self._start, self._scale = time.monotonic(), time_scale
        for step in steps:
            delay = self._start + step.at / time_scale - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            if step.action == "select":
                self.select(*step.value)
            elif step.action == "drive":
                self.drive(float(step.value[0]), float(step.value[1]), step.duration / time_scale)
            elif step.action == "stop":
                self.stop(step.duration / time_scale)
            else:
                self.release()
        time.sleep(0.2)  # let late replies (refusals) arrive
        return self.result

    def close(self) -> None:
        self.ros.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m terminal.operator", description=__doc__.split("\n\n")[0])
    parser.add_argument("script", help="YAML list of steps")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=9090)
    parser.add_argument("--token", default=None, help="the terminal's token, when it needs one")
    parser.add_argument("--time-scale", type=float, default=1.0, help="script seconds per wall second")
    args = parser.parse_args(argv)
    try:
        steps = read_script(args.script)
    except ScriptError as error:
        print(f"terminal.operator: error: {error}", file=sys.stderr)
        return 2
    operator = Operator(args.host, args.port, args.token)
    try:
        result = operator.run(steps, args.time_scale)
    finally:
        operator.close()
    print(json.dumps(result.as_json()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
