"""`subsumption run patrol --level 5`: the patrol robot with the remote operator terminal on top (Fig. 7(f)).

    subsumption run patrol --level 5 --world W [--map M] --duration T --runtime ros --out D
                           [--operator SCRIPT] [--host ADDR]

Level 5 is the terminal node of ``robots/patrol/patrol.yaml`` (terminal/: a web page and rosbridge v2 on one
port) wired in as the paper draws it: the operator's target through a suppressor over the autonomous one
(``operator_target``), its motor commands through a suppressor (``operator_drives``) and its stop through an
inhibitor (``operator_stops``), both nearest the base. The terminal is a ROS node on real sockets and real time,
so level 5 runs on ROS only (``--runtime ros``).

- With ``--operator SCRIPT`` a scripted operator (terminal.operator, roslibpy: the rosbridge v2 protocol any
  client speaks) plays the script in simulated seconds: it looks at the camera picture the terminal sends it
  and drags a box round the face it sees (``select: face``), presses Enter; the robot follows; it drives by hand;
  it lets go, and the robot patrols on. The default script is ``experiments/patrol_operator.yaml``.
- Without it, the run serves the page for its duration and prints, each on its own line, ``terminal:
  http://HOST:PORT/...`` (with the token when one is needed) and ``rosbridge: ws://HOST:PORT``: a person is the
  operator, in a browser.

``metrics.json`` adds ``operator_commands`` (messages the operator published), ``manual_control_s`` (simulated
s from its first command to its release), ``resumed_patrol_at_s`` (the simulated time after the release at which the
patrol robot's own levels 0-3 have the motor line again: every arbiter nearer the base than
``navigation_drives`` held by its lower line, the operator's and level 4's alike; which of levels 0-3 then drives
is theirs to say), and ``operator`` (the script's log: boxes selected, release time, refusals, selections that
found nothing, collision times, and ``navigation_at_s``: when after the release navigation's own commands held
the base, ``navigation_drives`` by its upper line), ``terminal`` (the URLs).
"""
from __future__ import annotations

import json
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import UInt32

from subsumption.network import load
from subsumption.runtime import NodeHandle
from terminal.operator import Operator, ScriptError, read_script
from vision.faces import FaceDetector

from .runner import ROBOTS

OPERATOR_LEVEL = 5
DEFAULT_SCRIPT = Path(__file__).with_name("patrol_operator.yaml")
OPERATOR_WORLD = Path(__file__).parent / "worlds" / "pingpong_operator_world.yaml"  # the scene the script is for
SCENE_DURATION = 120.0  # simulated s: the face shows from the start, the release comes about 18 s after the selection
NAVIGATION_ARBITER = "navigation_drives"
URL_WAIT = 120.0       # wall s for the terminal node to come up and write its URLs
FACE_MIN_PX = 16       # the smallest face the operator picks out in the terminal's picture


class OperatorSetupError(ValueError):
    """Level 5 asked for in a way that cannot run; the message names the option or file."""


def motor_chain(network_path: Path, level: int) -> tuple[str, list[str]]:
    """Navigation's arbiter on the motor line and every arbiter nearer the base than it (later in the file on the
    same lower line), which must all be held by their lower lines for navigation to drive."""
    network = load(network_path)
    arbiters = network.arbiters(level)
    names = [arbiter.name for arbiter in arbiters]
    if NAVIGATION_ARBITER not in names:
        raise OperatorSetupError(f"{network_path}: no arbiter {NAVIGATION_ARBITER!r} on the motor line")
    index = names.index(NAVIGATION_ARBITER)
    line = arbiters[index].lower
    return NAVIGATION_ARBITER, [a.name for a in arbiters[index + 1:] if a.lower == line]


def face_finder(min_face_px: int = FACE_MIN_PX):
    """What the scripted operator's eyes do: the largest face in a JPEG frame, as (x, y, width, height)."""
    detector = FaceDetector("haar_alt2", min_face_px=min_face_px)

    def find(jpeg: bytes) -> tuple[int, int, int, int] | None:
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
        if image is None:
            return None
        faces = detector.detect(image)
        if not faces:
            return None
        box = faces[0]
        return int(round(box.x)), int(round(box.y)), int(round(box.w)), int(round(box.h))

    return find


@dataclass
class OperatorSession:
    """The operator's side of a level-5 run: waits for the terminal's URLs, prints them, plays the script (if
    any) on the simulation's clock on a thread of its own, and watches the motor line's arbiters to see when
    the robot's own levels, and navigation itself, drive again after the release."""

    url_file: Path
    script: Path | None
    host: str
    navigation: str
    above: list[str]
    progress: bool = True
    urls: dict | None = None
    result: Any = None
    error: str = ""
    resumed_at: float | None = None
    navigation_at: float | None = None
    holders: dict[str, str] = field(default_factory=dict)
    collisions_at: list[float] = field(default_factory=list)  # simulated s of each new collision
    _collisions: int = 0
    _operator: Any = None
    _thread: threading.Thread | None = None
    _done: threading.Event = field(default_factory=threading.Event)
    terminal_record: dict | None = None  # what the terminal counted, whoever the client was (its ~status)

    def attach(self, node: NodeHandle) -> None:
        """Called with the run's recorder node before the network starts."""
        self.node = node
        for name in [self.navigation, *self.above]:
            node.subscribe(f"/{name}/status", DiagnosticStatus, lambda msg, n=name: self._on_status(n, msg))
        node.subscribe("/collisions", UInt32, self._on_collisions)
        node.subscribe("/terminal/status", DiagnosticStatus, self._on_terminal)  # the terminal's own record
        self._thread = threading.Thread(target=self._main, name="operator", daemon=True)
        self._thread.start()

    def _on_status(self, name: str, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        if "in_control" in values:
            self.holders[name] = values["in_control"]
        released = self.result.released_at_s if self.result is not None else None
        if released is None or self.navigation_at is not None:
            return
        own = all(self.holders.get(above, "lower") == "lower" for above in self.above)
        if own and self.resumed_at is None:
            self.resumed_at = self.node.now()
        if own and self.holders.get(self.navigation) == "upper":
            self.navigation_at = self.node.now()

    def _on_terminal(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        if "operator_commands" in values:
            self.terminal_record = {"operator_commands": int(values["operator_commands"]),
                                    "manual_control_s": float(values["manual_control_s"])}

    def _on_collisions(self, msg: UInt32) -> None:
        now = self.node.now()
        while self._collisions < msg.data:
            self._collisions += 1
            self.collisions_at.append(now)

    def _main(self) -> None:
        try:
            self.urls = self._wait_for_urls()
            if self.urls is None:
                return
            print(f"terminal: {self.urls['terminal']}", flush=True)
            print(f"rosbridge: {self.urls['rosbridge']}", flush=True)
            if self.script is not None:
                self._play()
        except Exception as error:  # the run goes on; the metrics say what went wrong
            self.error = f"operator: {type(error).__name__}: {error}"
            print(f"subsumption run: {self.error}", file=sys.stderr, flush=True)
        finally:
            self._done.set()

    def _wait_for_urls(self) -> dict | None:
        deadline = time.monotonic() + URL_WAIT
        while time.monotonic() < deadline and not self._done.is_set():
            if self.url_file.exists():
                return json.loads(self.url_file.read_text())
            time.sleep(0.1)
        if not self._done.is_set():
            self.error = f"the terminal did not write {self.url_file} within {URL_WAIT:g} s (see its log)"
            print(f"subsumption run: {self.error}", file=sys.stderr, flush=True)
        return None

    def _play(self) -> None:
        steps = read_script(self.script)
        connect = "127.0.0.1" if self.host in ("0.0.0.0", "::", "") else self.host
        self._operator = Operator(connect, int(self.urls["port"]), self.urls.get("token"))
        self.result = self._operator.result
        try:
            self._operator.run(steps, clock=self.node.now, finders={"face": face_finder()}, start=0.0)
        finally:
            self._operator.close()

    def finish(self) -> None:
        """The run is over: end the script where it is."""
        if self._operator is not None:
            self._operator.cancelled.set()
        self._done.set()
        if self._thread is not None:
            self._thread.join(10.0)

    def metrics(self) -> dict:
        played = self.result.as_json() if self.result is not None else {}
        # the terminal's own count when it gave one (a person at a browser is counted too), else the script's
        counted = self.terminal_record or {}
        manual = counted.get("manual_control_s") if counted.get("operator_commands") else None
        return {
            "operator_commands": counted.get("operator_commands", played.get("operator_commands", 0)),
            "manual_control_s": _rounded(manual if manual is not None else played.get("manual_control_s")),
            "resumed_patrol_at_s": _rounded(self.resumed_at),
            "operator": {"script": str(self.script) if self.script else None,
                         "released_at_s": _rounded(played.get("released_at_s")),
                         "selected": played.get("selected", []), "missed": played.get("missed", []),
                         "refusals": played.get("refusals", []), "error": self.error,
                         "script_commands": played.get("operator_commands", 0),
                         "collisions_at_s": [_rounded(t) for t in self.collisions_at],
                         "navigation_at_s": _rounded(self.navigation_at)},
            "terminal": {key: (self.urls or {}).get(key) for key in ("terminal", "rosbridge")},
        }


def _rounded(value: float | None) -> float | None:
    return None if value is None else round(float(value), 2)


def check_script(script: Path | None) -> None:
    """Read the script before anything starts: every problem names the file and the step."""
    if script is None:
        return
    try:
        steps = read_script(script)
    except ScriptError as error:
        raise OperatorSetupError(str(error)) from None
    for index, step in enumerate(steps, 1):
        if step.action == "select" and isinstance(step.value, str) and step.value != "face":
            raise OperatorSetupError(f"{script}: step {index}: select: {step.value}: the patrol's operator "
                                     f"knows 'face' (or give [x, y, width, height])")


def operator_extension(run, script: Path | None = DEFAULT_SCRIPT, host: str = "127.0.0.1"):
    """What makes a patrol run level 5: `run` (an experiments.patrol.PatrolRun on the ros runtime) gets the
    terminal on `host` and the scripted operator `script` (None: nobody; the page is served and its URLs
    printed). Checks the request (OperatorSetupError names the option or file) and returns the `extend` that
    experiments.patrol.execute takes: it changes the RunSpec before the run and returns what adds level 5's
    metrics after it. (Handed to execute rather than calling it: the patrol runner stays below its levels.)"""
    if run.level < OPERATOR_LEVEL:
        raise OperatorSetupError(f"the operator terminal is level {OPERATOR_LEVEL}; --level is {run.level}")
    if run.runtime != "ros":
        raise OperatorSetupError(f"level {OPERATOR_LEVEL} (the operator terminal) is a ROS node on real sockets "
                                 f"and real time: it needs --runtime ros")
    check_script(script)
    network = ROBOTS["patrol"]
    navigation, above = motor_chain(network, run.level)
    logs = run.out.resolve() / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    url_file = logs / "terminal_urls.json"
    url_file.unlink(missing_ok=True)
    session = OperatorSession(url_file, script.resolve() if script else None, host, navigation, above,
                              run.progress)

    def extend(spec):
        spec.params.update({"terminal.port": 0, "terminal.host": host, "terminal.url_file": str(url_file),
                            "terminal.network": str(network), "terminal.level": run.level})
        inner = spec.observe

        def observe(node):
            observed = inner(node) if inner else None
            session.attach(node)
            return observed

        spec.observe = observe

        def finish(result):
            session.finish()
            if "resumed_patrol_at_s" in result.metrics:  # level 4's: after its pursuit ended
                result.metrics["pursuit_resumed_patrol_at_s"] = result.metrics["resumed_patrol_at_s"]
            result.metrics.update(session.metrics())

        return finish

    return extend
