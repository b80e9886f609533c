"""``subsumption replay BAG --level N``: a recorded run as a regression test of the network's behaviour.

A bag recorded while the robot ran (``rosbag record -a``, or ``subsumption run ... --bag``) holds both what the
sensors said and what every module and arbiter answered. Replay plays the sensor topics back on simulated
time into a fresh network of levels 0..N and compares what the modules publish now with what the bag
recorded then, topic by topic:

- ``--runtime ros`` (default): the real graph. A private master, ``/use_sim_time``, the network through
  roslaunch (every module and arbiter its own node), and ``rosbag play --clock --topics <sensors>``, so the
  nodes run on the bag's clock exactly as they ran on the simulator's.
- ``--runtime local``: the same network in the in-process runtime, fed the bag's sensor messages at their
  recorded times: no processes, deterministic, seconds for minutes of recording.

Sensor topics are the network's external topics that modules read (``sonar``, ``scan``, ``odom``); compared
topics are the lines modules and arbiters write (``/feelforce/force``, ``/cmd_vel``, ...) that the bag holds.
A recorded message is *matched* when the replay sent an equal message (every field; numbers to
``value_tolerance``; ``header.seq`` ignored, as it counts per publisher) within ``time_tolerance`` seconds of
its recorded time. A message with a header stamp is timed by its stamp on both sides (the sensor time it
answers, equal in an equal message), one without by when it arrived: so a loaded machine, slow to pass
stamped messages on, cannot turn equal answers into misses. A topic passes when matches / max(recorded, replayed) reaches ``min_match``. Messages are
compared from the moment the bag holds every topic played (``rosbag record -a`` joins each topic a little after
it appears) to the bag's end.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

import rosbag
import rosgraph
from roslib.message import get_message_class

from ..network.spec import Network
from ..network.wiring import Wiring, wire

Timed = list[tuple[float, Any]]  # (seconds of ROS time, message)


class ReplayError(RuntimeError):
    """A bag or network that cannot be replayed; the message names the bag, topic or module."""


# What to play and what to compare ---------------------------------------------------------------------------
PLAY_MARGIN = 60.0  # wall s rosbag play may take beyond the recording's length (waiting for subscribers)
REPLAYED_NS = "/replayed"  # isolated replay: where modules and arbiters write, beside the recorded topics


@dataclass
class ReplayPlan:
    wiring: Wiring             # what runs (in isolation: outputs moved under REPLAYED_NS)
    played: dict[str, str]     # global topic -> message type, played from the bag
    compared: dict[str, str]   # global topic as recorded -> message type
    replayed_as: dict[str, str]  # recorded topic -> the topic the replay writes it on
    unrecorded: list[str]      # lines of the network the bag does not hold (not compared)


def plan(network: Network, level: int | None, bag_topics: dict[str, str], isolated: bool = False) -> ReplayPlan:
    """Which of the bag's topics feed the network and which of its lines can be compared.

    Whole network (default): only the sensors are played; every module works from what the modules before it
    send now, as on the robot. Isolated: every module and arbiter is fed its own recorded inputs and writes
    under /replayed, so a difference shows at the module that makes it instead of at everything downstream."""
    wiring = wire(network, level)
    sensors = {"/" + w.topic.lstrip("/"): w.type or "" for w in wiring.wires if w.source.kind == "external"}
    lines = {"/" + w.topic.lstrip("/"): w.type or "" for w in wiring.wires if w.source.kind != "external"}
    read = {"/" + w.topic.lstrip("/") for w in wiring.wires if w.target.kind != "external"}
    missing = [topic for topic in sensors if topic not in bag_topics]
    if missing:
        raise ReplayError(f"the bag has no {', '.join(missing)}: levels 0..{wiring.level} of network "
                          f"{network.name} read {'it' if len(missing) == 1 else 'them'}")
    for topic, msg_type in {**sensors, **lines}.items():
        if topic in bag_topics and bag_topics[topic] != msg_type:
            raise ReplayError(f"topic {topic} is {bag_topics[topic]} in the bag but the network says {msg_type}")
    compared = {topic: t for topic, t in lines.items() if topic in bag_topics}
    if not compared:
        raise ReplayError(f"the bag records none of the lines of levels 0..{wiring.level} of network "
                          f"{network.name} ({', '.join(sorted(lines))}): nothing to compare")
    played = dict(sensors)
    replayed_as = {topic: topic for topic in compared}
    if isolated:
        _isolate(wiring)
        played.update({topic: t for topic, t in compared.items() if topic in read})  # as recorded
        replayed_as = {topic: REPLAYED_NS + topic for topic in compared}
    return ReplayPlan(wiring, played, compared, replayed_as, sorted(set(lines) - set(compared)))


def _isolate(wiring: Wiring) -> None:
    """Move every module output and arbiter output under REPLAYED_NS; inputs keep reading the recorded topics."""
    for module in wiring.modules:
        for name, port in module.ports.outputs.items():
            own = port.own_topic
            recorded = module.remaps.get(own) or (f"{module.name}/{name}" if own.startswith("~") else own)
            module.remaps[own] = REPLAYED_NS + "/" + recorded.lstrip("/")
    for arbiter in wiring.arbiters:
        arbiter.output = REPLAYED_NS + "/" + arbiter.output.lstrip("/")


def read_bag(path: Path) -> tuple[dict[str, str], float, float]:
    """The bag's topics with their types, and its start and end times; a ReplayError for an unreadable bag."""
    try:
        with rosbag.Bag(str(path)) as bag:
            info = bag.get_type_and_topic_info()
            return ({topic: t.msg_type for topic, t in info.topics.items()}, bag.get_start_time(),
                    bag.get_end_time())
    except (OSError, rosbag.ROSBagException, ValueError) as error:
        raise ReplayError(f"{path}: cannot read the bag: {error}") from error


def first_times(path: Path, topics: Iterable[str]) -> dict[str, float]:
    """When each topic's first message was sent: its stamp, or when it was recorded if it has none."""
    found = {}
    with rosbag.Bag(str(path)) as bag:
        for topic in topics:
            for _, msg, stamp in bag.read_messages(topics=[topic]):
                found[topic] = by_stamp([(stamp.to_sec(), msg)])[0][0]
                break
    return found


def messages(path: Path, topics: Iterable[str]) -> dict[str, Timed]:
    """Every message of `topics` in the bag with the time it was recorded."""
    found: dict[str, Timed] = {topic: [] for topic in topics}
    with rosbag.Bag(str(path)) as bag:
        for topic, msg, stamp in bag.read_messages(topics=list(found)):
            found[topic].append((stamp.to_sec(), msg))
    return found


# Comparing ------------------------------------------------------------------------------------------------
@dataclass
class TopicResult:
    topic: str
    recorded: int
    replayed: int
    matched: int
    first_mismatch: str = ""   # the first recorded message with no match, described

    @property
    def score(self) -> float:
        """The share of the topic's messages matched (matched over the larger of recorded and replayed)."""
        most = max(self.recorded, self.replayed)
        return self.matched / most if most else 1.0


def fields(msg: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """A message as (path, value) leaves, header.seq left out."""
    slots = getattr(msg, "__slots__", None)
    if slots is None or not hasattr(msg, "_slot_types"):
        if hasattr(msg, "to_nsec"):  # genpy Time / Duration
            return [(prefix, msg.to_nsec())]
        if isinstance(msg, (list, tuple)) and msg and hasattr(msg[0], "__slots__"):
            return [leaf for i, item in enumerate(msg) for leaf in fields(item, f"{prefix}[{i}]")]
        return [(prefix, msg)]
    leaves = []
    for name in slots:
        if name == "seq" and getattr(msg, "_type", "") == "std_msgs/Header":
            continue
        leaves += fields(getattr(msg, name), f"{prefix}.{name}" if prefix else name)
    return leaves


def _close(a: Any, b: Any, tolerance: float) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        if not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
            return False
        if math.isnan(a) and math.isnan(b):
            return True
        return a == b or abs(a - b) <= tolerance * max(1.0, abs(a), abs(b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_close(x, y, tolerance) for x, y in zip(a, b))
    return a == b


def same(a: Any, b: Any, tolerance: float) -> bool:
    """Whether two messages have the same fields, numbers equal within the relative `tolerance`."""
    left, right = fields(a), fields(b)
    return len(left) == len(right) and all(p == q and _close(x, y, tolerance)
                                           for (p, x), (q, y) in zip(left, right))


def compare_topic(topic: str, recorded: Timed, replayed: Timed, time_tolerance: float,
                  value_tolerance: float) -> TopicResult:
    """Match each recorded message with an equal replayed one within `time_tolerance` s (each used once)."""
    used = [False] * len(replayed)
    start = matched = 0
    first = ""
    for when, msg in recorded:
        while start < len(replayed) and replayed[start][0] < when - time_tolerance:
            start += 1
        index = start
        hit = False
        while index < len(replayed) and replayed[index][0] <= when + time_tolerance:
            if not used[index] and same(msg, replayed[index][1], value_tolerance):
                used[index] = hit = True
                break
            index += 1
        if hit:
            matched += 1
        elif not first:
            first = f"t={when:.2f} s: {_short(msg)}"
    return TopicResult(topic, len(recorded), len(replayed), matched, first)


def _short(msg: Any) -> str:
    from ..brief import brief
    return brief(msg, 100)


@dataclass
class ReplayReport:
    bag: Path
    level: int
    runtime: str
    isolated: bool
    results: list[TopicResult]
    unrecorded: list[str] = field(default_factory=list)
    min_match: float = 0.95
    window: tuple[float, float] = (0.0, math.inf)  # recorded times compared

    @property
    def passed(self) -> bool:
        """True when every compared topic matched at least `min_match` of its messages."""
        return all(result.score >= self.min_match for result in self.results)

    def table(self) -> str:
        """The report as a text table, one row per compared topic."""
        how = "each module fed its recorded inputs" if self.isolated else "sensors only"
        lines = [f"replay of {self.bag} into levels 0..{self.level} ({self.runtime} runtime, {how}): a topic "
                 f"passes at {self.min_match:.0%} matched; compared from {self.window[0]:.2f} s (when the bag "
                 f"holds every topic played) to {self.window[1]:.2f} s",
                 f"{'topic':<36} {'recorded':>8} {'replayed':>8} {'matched':>8} {'score':>7}  result"]
        for r in self.results:
            verdict = "ok" if r.score >= self.min_match else f"DIFFERS (first unmatched: {r.first_mismatch})"
            lines.append(f"{r.topic:<36} {r.recorded:>8} {r.replayed:>8} {r.matched:>8} {r.score:>7.1%}  {verdict}")
        if self.unrecorded:
            lines.append(f"not in the bag, not compared: {', '.join(self.unrecorded)}")
        lines.append("PASS" if self.passed else "FAIL")
        return "\n".join(lines)


def by_stamp(timed: Timed) -> Timed:
    """Messages timed by their header stamp where they carry one (non-zero), else by arrival; in time order."""
    def when(arrived: float, msg: Any) -> float:
        stamp = getattr(getattr(msg, "header", None), "stamp", None)
        return stamp.to_sec() if stamp is not None and hasattr(stamp, "to_sec") and not stamp.is_zero() else arrived
    return sorted(((when(t, msg), msg) for t, msg in timed), key=lambda pair: pair[0])


def compare(recorded: dict[str, Timed], replayed: dict[str, Timed], time_tolerance: float,
            value_tolerance: float) -> list[TopicResult]:
    """Each recorded topic against the replay's messages for it (keyed by the recorded topic)."""
    return [compare_topic(topic, recorded[topic], replayed.get(topic, []), time_tolerance, value_tolerance)
            for topic in sorted(recorded)]


# Running ------------------------------------------------------------------------------------------------
def replay_local(replay_plan: ReplayPlan, bag: Path, start: float, end: float) -> dict[str, Timed]:
    """The network in a LocalRuntime, fed the bag's messages at their recorded times. The clock starts at the
    whole second before the bag's start (0 for a simulator's recording), so that timers keep the phase they
    had when the nodes started before the simulator's clock."""
    from ..local import LocalRuntime
    from ..network.local import build_wired

    runtime = LocalRuntime(start_time=math.floor(start))
    build_wired(replay_plan.wiring, runtime)
    player = runtime.node("replay_player")
    publishers = {topic: player.publisher(topic, get_message_class(t)) for topic, t in replay_plan.played.items()}
    replayed: dict[str, Timed] = {topic: [] for topic in replay_plan.compared}
    listener = runtime.node("replay_recorder")
    for topic, msg_type in replay_plan.compared.items():
        listener.subscribe(replay_plan.replayed_as[topic], get_message_class(msg_type),
                           lambda msg, out=replayed[topic]: out.append((runtime.now(), msg)))
    with rosbag.Bag(str(bag)) as recording:
        for topic, msg, stamp in recording.read_messages(topics=list(publishers)):
            runtime.run_until(stamp.to_sec())
            publishers[topic].publish(msg)
    runtime.run_until(end)
    return replayed


def replay_ros(replay_plan: ReplayPlan, bag: Path, rate: float, log_dir: Path, duration: float,
               settle: float = 1.0) -> dict[str, Timed]:
    """The network on a private ROS master, the bag's topics played with ``rosbag play --clock``."""
    import rospy

    from .launch import Launched, NetworkNotReady, launch_env, launch_xml, network_nodes, wait_for_nodes
    from .master import start_master

    master = start_master()
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri))
    os.environ["ROS_MASTER_URI"] = master.uri  # this process's recorder node uses it too
    launched = player = None
    log_dir.mkdir(parents=True, exist_ok=True)
    try:
        rosgraph.Master("/subsumption_replay", master_uri=master.uri).setParam("/use_sim_time", True)
        xml = log_dir / "replay.launch"
        launch_xml(replay_plan.wiring).write(xml, encoding="unicode", xml_declaration=True)
        launched = Launched(subprocess.Popen(["roslaunch", str(xml)], env=env, start_new_session=True,
                                             stdout=open(log_dir / "roslaunch.log", "w"), stderr=subprocess.STDOUT),
                            xml)
        rospy.init_node("replay_recorder", argv=["replay_recorder"], disable_signals=True)
        replayed: dict[str, Timed] = {topic: [] for topic in replay_plan.compared}
        for topic, msg_type in replay_plan.compared.items():
            rospy.Subscriber(replay_plan.replayed_as[topic], get_message_class(msg_type),
                             lambda msg, out=replayed[topic]: out.append((rospy.get_time(), msg)), queue_size=1000)
        names, built = network_nodes(replay_plan.wiring)
        try:
            wait_for_nodes(names, launched, built=built)
        except NetworkNotReady as error:
            raise ReplayError(str(error)) from None
        player = subprocess.Popen(["rosbag", "play", "--clock", "--hz=200", f"--rate={rate}", "-d", "0.5",
                                   "--wait-for-subscribers", str(bag), "--topics", *replay_plan.played],
                                  env=env, stdout=open(log_dir / "rosbag_play.log", "w"), stderr=subprocess.STDOUT,
                                  start_new_session=True)
        try:
            status = player.wait(timeout=duration / rate + PLAY_MARGIN)  # wall clock: a process playing
        except subprocess.TimeoutExpired:
            raise ReplayError(f"rosbag play did not finish within {duration / rate + PLAY_MARGIN:.0f} s; see "
                              f"{log_dir}/rosbag_play.log") from None
        if status != 0:
            raise ReplayError(f"rosbag play exited with status {status}; see {log_dir}/rosbag_play.log")
        time.sleep(settle)  # wall clock: let the last answers arrive
        return replayed
    finally:
        if player is not None and player.poll() is None:
            player.send_signal(2)
            player.wait(10)
        if launched is not None:
            launched.stop()
        master.stop()


def set_overrides(network: Network, seed: int | None, params: dict[str, Any]) -> None:
    """The recording's seed (for every module with a `seed` parameter, as `subsumption run --seed` does) and
    "module.param" values, over the network file's."""
    from ..loading import load_module_class

    if seed is not None:
        for module in network.modules():
            if module.class_path and "seed" in load_module_class(module.class_path).interface.params:
                module.params["seed"] = seed
    for key, value in params.items():
        module_name, _, param = key.partition(".")
        module = network.module(module_name)
        if module is None or not param:
            raise ReplayError(f"--param {key}: no module {module_name!r} in {network.file}")
        module.params[param] = value


def replay(network: Network, level: int | None, bag: Path, runtime: str = "ros", rate: float = 1.0,
           isolated: bool = False, time_tolerance: float = 0.25, value_tolerance: float = 1e-6,
           min_match: float = 0.95, log_dir: Path | None = None,
           notice: Callable[[str], None] = lambda text: None) -> ReplayReport:
    """Replay `bag` into levels 0..`level` of `network` and compare; see the module's documentation. `notice` is
    told, before anything runs, what the bag cannot show (the CLI prints it)."""
    topics, start, end = read_bag(bag)
    replay_plan = plan(network, level, topics, isolated)
    # rosbag record -a subscribes to each topic some time after it appears: what the bag recorded before it
    # held every topic the replay plays cannot come out of the replay, so the comparison starts there. Times
    # are stamps where messages have them (see by_stamp): an answer recorded late under load, to an input sent
    # before the bag began, is left out by its stamp.
    compared_from = max(first_times(bag, replay_plan.played).values())
    late = {topic: t - start for topic, t in first_times(bag, replay_plan.played).items() if t - start > LATE_JOIN}
    if late and not isolated:
        notice(late_join_notice(bag, late))
    recorded = {topic: [(t, msg) for t, msg in by_stamp(sent) if t >= compared_from]
                for topic, sent in messages(bag, replay_plan.compared).items()}
    if runtime == "local":
        replayed = replay_local(replay_plan, bag, start, end)
    else:
        log_dir = log_dir or Path(os.environ.get("TMPDIR", "/tmp")) / f"subsumption_replay_{os.getpid()}"
        replayed = replay_ros(replay_plan, bag, rate, log_dir, end - start)
    # The recording says nothing of what came after its last message: neither does the comparison.
    replayed = {topic: [(t, msg) for t, msg in by_stamp(sent) if compared_from <= t <= end]
                for topic, sent in replayed.items()}
    results = compare(recorded, replayed, time_tolerance, value_tolerance)
    return ReplayReport(bag, replay_plan.wiring.level, runtime, isolated, results, replay_plan.unrecorded,
                        min_match, (compared_from, end))


LATE_JOIN = 0.2  # s after the bag's first message: a played topic first recorded later was joined late


def late_join_notice(bag: Path, late: dict[str, float]) -> str:
    """What a bag whose played topics were joined late cannot show as a whole network, said before the replay runs
    (instead of a table of FAILs to explain afterwards: docs/ros.md, 'subsumption replay')."""
    joined = ", ".join(f"{topic} {seconds:.1f} s" for topic, seconds in sorted(late.items()))
    return (f"note: {bag} recorded some played topics only after its start ({joined} in: rosbag record -a joins a topic "
            "when it appears). What a module heard before then is not in the bag: a module that keeps it (a register, "
            "an AFSM's state, wander's first heading from the first odometry) starts differently in the replay, and "
            "everything downstream of it with it, so the whole network may FAIL where each module is right. "
            "--isolated feeds every module its own recorded inputs and shows the module that differs; record with "
            "`rosbag record TOPICS` started before the robot to keep the start.")


def default_network() -> Path:
    """The wander robot's network file, wherever the `robots` package is installed (a checkout, pip, catkin)."""
    from importlib.util import find_spec

    spec = find_spec("robots.wander")
    if spec is None or not spec.submodule_search_locations:
        raise ReplayError("no default network: the robots package is not installed; give --network FILE")
    return Path(list(spec.submodule_search_locations)[0]) / "wander.yaml"


def main_replay(args: Any) -> int:
    """The CLI's `replay` command."""
    from ..network import load
    from ..network.spec import NetworkInvalid

    try:
        network = load(args.network or default_network())
        set_overrides(network, args.seed, dict(args.param or []))
        report = replay(network, args.level, Path(args.bag), args.runtime, args.rate, args.isolated,
                        args.time_tolerance, args.value_tolerance, args.min_match,
                        notice=lambda text: print(f"subsumption replay: {text}", file=sys.stderr, flush=True))
    except (ReplayError, NetworkInvalid, FileNotFoundError) as error:
        print(f"subsumption replay: {error}", file=sys.stderr)
        return 2
    print(report.table())
    return 0 if report.passed else 1
