"""A scripted operator: what a person does at the terminal's page, done by a program through the same protocol.

It connects to the terminal's rosbridge WebSocket with roslibpy, exactly as any rosbridge client would, and
publishes on the terminal's command topics. A script is a YAML list of steps, each at a time in seconds after
the start (divided by ``--time-scale``, so a script written in simulated seconds fits a simulation running
at that many times real time)::

    - {at: 5.0, select: [120, 60, 80, 160]}        # drag a box (x, y, width, height in image pixels), Enter
    - {at: 5.0, select: face, within: 30}          # ... around what a finder sees in the camera (below)
    - {at: 12.0, drive: [0.2, 0.0], for: 2.0}      # hold a drive key: linear m/s, angular rad/s
    - {at: 15.0, stop: 1.0}                        # hold stop (the inhibitor) for 1 s
    - {at: 20.0, release: true}                    # hand control back
    - {after: 2.0, release: true}                  # (or: 2 s after the previous step ended)

    python -m terminal.operator SCRIPT --port 9090 [--host H] [--token T] [--time-scale 3]

It prints one JSON line: ``operator_commands`` (messages published), ``manual_control_s`` (from the first
command to the release, in script seconds), ``released_at_s`` and any refusals the terminal sent.

A ``select`` by name (``select: face``) is the operator looking at the camera picture the terminal shows it
(its camera topic, subscribed through the same WebSocket) and drawing the box round what it sees there: a
*finder*, given by the program that runs the script (``Operator.run(..., finders={"face": f})``, where
``f(jpeg_bytes)`` returns a box or None), tried on each new frame until it finds one or ``within`` script seconds
pass. The terminal package knows no finder itself (it depends on the core only); the patrol robot's operator
(experiments/patrol_operator.py) gives one. Times can follow any clock (``clock=``, e.g. a simulation's).
"""
from __future__ import annotations

import argparse
import base64
import json
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import yaml

Box = tuple[int, int, int, int]
Finder = Callable[[bytes], "Box | None"]

ACTIONS = ("select", "drive", "stop", "release")


class ScriptError(ValueError):
    """A script step that cannot be run; the message names the file and the step."""


@dataclass
class Step:
    at: float           # script seconds; with `relative`, after the previous step ended
    action: str
    value: Any
    duration: float = 0.0
    relative: bool = False


@dataclass
class Result:
    operator_commands: int = 0
    first_command_s: float | None = None
    released_at_s: float | None = None
    selected: list[tuple[float, Box]] = field(default_factory=list)  # (script s, box) of every target sent
    missed: list[str] = field(default_factory=list)  # selections whose finder found nothing in time
    refusals: list[str] = field(default_factory=list)

    def as_json(self) -> dict[str, Any]:
        """The operator's record for metrics.json: commands, manual control time, release, selections."""
        manual = None
        if self.first_command_s is not None:
            manual = (self.released_at_s if self.released_at_s is not None else self.first_command_s) - \
                self.first_command_s
        return {"operator_commands": self.operator_commands, "manual_control_s": manual,
                "released_at_s": self.released_at_s,
                "selected": [{"at_s": round(t, 2), "box": list(box)} for t, box in self.selected],
                "missed": self.missed, "refusals": self.refusals}


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
        when = [key for key in ("at", "after") if isinstance(item, dict) and key in item]
        if len(when) != 1 or isinstance(item[when[0]], bool) or not isinstance(item[when[0]], (int, float)) \
                or item[when[0]] < 0:
            raise ScriptError(f"{where}: needs 'at' (script seconds >= 0) or 'after' (seconds after the previous "
                              f"step ended)")
        actions = [key for key in item if key in ACTIONS]
        if len(actions) != 1:
            raise ScriptError(f"{where}: needs exactly one of {', '.join(ACTIONS)}")
        action = actions[0]
        value = item[action]
        if action == "select" and not (isinstance(value, list) and len(value) == 4
                                       and all(isinstance(v, int) and v >= 0 for v in value)) \
                and not (isinstance(value, str) and value.isidentifier()):
            raise ScriptError(f"{where}: select is [x, y, width, height], whole pixels >= 0, or the name of a "
                              f"finder (select: face)")
        within = item.get("within", 30.0)
        if action == "select" and (not isinstance(within, (int, float)) or within <= 0):
            raise ScriptError(f"{where}: within (seconds a finder may look) must be > 0")
        if action == "drive" and not (isinstance(value, list) and len(value) == 2
                                      and all(isinstance(v, (int, float)) for v in value)):
            raise ScriptError(f"{where}: drive is [linear m/s, angular rad/s]")
        duration = item.get("for", value if action == "stop" else 0.0)
        if action in ("drive", "stop") and (not isinstance(duration, (int, float)) or duration <= 0):
            raise ScriptError(f"{where}: {action} needs a duration > 0 ('for: SECONDS', or 'stop: SECONDS')")
        if action == "select" and isinstance(value, str):
            duration = within
        steps.append(Step(float(item[when[0]]), action, value, float(duration), when[0] == "after"))
    if any(step.relative for step in steps):
        return steps  # the file's order is the order
    return sorted(steps, key=lambda step: step.at)


class Operator:
    """The terminal's commands through roslibpy; every method blocks for the time the action takes."""

    def __init__(self, host: str, port: int, token: str | None = None, prefix: str = "terminal/",
                 period: float = 0.05, camera: str = "camera/rgb/image_raw/compressed") -> None:
        import roslibpy

        self._roslibpy = roslibpy
        headers = {"Authorization": f"Bearer {token}"} if token else None
        self.ros = roslibpy.Ros(host, port, headers=headers)
        self.ros.run()
        self.period = period
        self.result = Result()
        self._clock: Callable[[], float] = time.monotonic
        self._start = self._clock()
        self._scale = 1.0
        self._lock = threading.Lock()
        self.cancelled = threading.Event()  # set by another thread: the script ends at once
        self._camera_name = camera
        self._camera = None
        self._frame: bytes | None = None
        self._frame_serial = 0
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
        """Script seconds since the start."""
        return (self._clock() - self._start) * self._scale

    def _sleep_until(self, script_s: float) -> None:
        while self._now() < script_s and not self.cancelled.is_set():
            time.sleep(min(0.02, max(0.001, (script_s - self._now()) / self._scale)))

    def _on_frame(self, msg: dict) -> None:
        with self._lock:
            self._frame = base64.b64decode(msg.get("data", ""))
            self._frame_serial += 1

    def latest_frame(self) -> tuple[int, bytes | None]:
        """The newest camera frame (JPEG bytes) the terminal sent, and its serial number (0: none yet)."""
        if self._camera is None:
            self._camera = self._roslibpy.Topic(self.ros, self._camera_name, "sensor_msgs/CompressedImage",
                                                throttle_rate=100, queue_length=1)
            self._camera.subscribe(self._on_frame)
        with self._lock:
            return self._frame_serial, self._frame

    def find(self, finder: Finder, until_s: float) -> Box | None:
        """Look at each new frame with `finder` until it sees something or `until_s` (script seconds)."""
        seen = 0
        while self._now() < until_s and not self.cancelled.is_set():
            serial, frame = self.latest_frame()
            if serial != seen and frame is not None:
                seen = serial
                box = finder(frame)
                if box is not None:
                    return box
            time.sleep(0.02)
        return None

    def _publish(self, name: str, msg: dict) -> None:
        self.topics[name].publish(self._roslibpy.Message(msg))
        self.result.operator_commands += 1
        if self.result.first_command_s is None:
            self.result.first_command_s = self._now()

    def select(self, x: int, y: int, width: int, height: int) -> None:
        """Select a target box (pixels) on the camera image, as a drag and Enter on the page does."""
        self._publish("target", {"x_offset": x, "y_offset": y, "width": width, "height": height,
                                 "do_rectify": False})
        self.result.selected.append((self._now(), (x, y, width, height)))

    def drive(self, linear: float, angular: float, seconds: float) -> None:
        """Hold a drive key for `seconds` (script seconds); the page's rhythm: a command every `period` of
        wall time, which the terminal's dead-man switch expects."""
        end = self._now() + seconds
        while self._now() < end and not self.cancelled.is_set():
            self._publish("cmd_vel", {"linear": {"x": linear}, "angular": {"z": angular}})
            time.sleep(self.period)
        self._publish("cmd_vel", {})  # the key let go: stop

    def stop(self, seconds: float) -> None:
        """Press stop for `seconds` (a stop message every 0.1 s)."""
        end = self._now() + seconds
        while self._now() < end and not self.cancelled.is_set():
            self._publish("stop", {})
            time.sleep(0.1)

    def release(self) -> None:
        """Let go of control: the robot's own levels drive again."""
        self._publish("release", {})
        self.result.released_at_s = self._now()

    def run(self, steps: list[Step], time_scale: float = 1.0, clock: Callable[[], float] | None = None,
            finders: dict[str, Finder] | None = None, start: float | None = None) -> Result:
        """Play the steps at their times: script seconds are `clock` seconds (default: wall time) times
        `time_scale`, from `start` on `clock` (default: now). A `select` by name uses `finders[name]`."""
        finders = finders or {}
        for step in steps:
            if step.action == "select" and isinstance(step.value, str) and step.value not in finders:
                raise ScriptError(f"select: {step.value}: no such finder here (known: "
                                  f"{', '.join(sorted(finders)) or 'none'})")
        self._clock = clock or time.monotonic
        self._start, self._scale = (self._clock() if start is None else start), time_scale
        if any(step.action == "select" and isinstance(step.value, str) for step in steps):
            self.latest_frame()  # subscribe now: frames are there by the time a select looks
        ended = 0.0
        for step in steps:
            self._sleep_until(ended + step.at if step.relative else step.at)
            if self.cancelled.is_set():
                break
            started = self._now()
            if step.action == "select":
                if isinstance(step.value, str):
                    box = self.find(finders[step.value], started + step.duration)
                    if box is None:
                        self.result.missed.append(f"select: {step.value} at {step.at:g} s: nothing seen within "
                                                  f"{step.duration:g} s")
                        continue
                    self.select(*(int(v) for v in box))
                else:
                    self.select(*step.value)
            elif step.action == "drive":
                self.drive(float(step.value[0]), float(step.value[1]), step.duration)
            elif step.action == "stop":
                self.stop(step.duration)
            else:
                self.release()
            ended = self._now()
        time.sleep(0.2)  # let late replies (refusals) arrive
        return self.result

    def close(self) -> None:
        """Close the connection to the terminal."""
        if self._camera is not None:
            self._camera.unsubscribe()
        self.ros.close()


def main(argv: list[str] | None = None) -> int:
    """``python -m terminal.operator SCRIPT``: play a scripted operator against a running terminal."""
    parser = argparse.ArgumentParser(prog="python -m terminal.operator", description=__doc__.split("\n\n")[0])
    parser.add_argument("script", help="YAML list of steps")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=9090)
    parser.add_argument("--token", default=None, help="the terminal's token, when it needs one")
    parser.add_argument("--time-scale", type=float, default=1.0, help="script seconds per wall second")
    args = parser.parse_args(argv)
    try:
        steps = read_script(args.script)
        named = [step for step in steps if step.action == "select" and isinstance(step.value, str)]
        if named:
            raise ScriptError(f"{args.script}: select: {named[0].value} at {named[0].at:g} s: this command has no "
                              f"finders; give the box as [x, y, width, height]")
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
