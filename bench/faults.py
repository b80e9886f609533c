"""Brooks' promise, measured: kill a part of the wander robot (level 2) on the real ROS graph mid-run.

Each case runs in a process of its own, on a master of its own, with the pieces `subsumption run --runtime
ros` uses (the network's roslaunch file from subsumption.ros.launch, the simulator node on /clock). At
--kill-at simulated seconds it kills one node: each module of levels 1 and 2, by `rosnode kill` and by
SIGKILL of its process, and each arbiter, both ways; and the simulator (SIGKILL), started again. Then it
watches for --after simulated seconds and prints, per case:

- collisions (the simulator's count over the whole run);
- moving: whether the robot still went > 1 m in the last part of the run (after kill + 5 s);
- lower holds: simulated seconds from the kill until every arbiter downstream of the dead node (those of the
  dead node's level and above that are still alive) reported its lower line in control on ~status;
- stopped: for a dead arbiter, seconds until the robot stood still (speed < 0.02 m/s), '-' if it kept moving;
- said: what roslaunch's log, /rosout (warnings and errors) and the arbiters' ~status said.

    .venv/bin/python -m bench.faults [--cases look,pathplan:sigkill] [--kill-at 30] [--after 45] [--rate 3]

With ``--groups level`` the robot runs one process per level (docs/ros.md, "Module groups") and the cases kill a
level's process: ``wander_level2`` (explore; its arbiters live with the lines they sit on, in level 1's process)
and ``wander_level1`` (wander; its suppressor lives in level 0's), each by ``rosnode kill`` and by SIGKILL.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client
from pathlib import Path

from subsumption.planar import yaw_of

ROOT = Path(__file__).resolve().parent.parent

WORLD = ROOT / "subsim" / "maps" / "room_world.yaml"
NETWORK = ROOT / "robots" / "wander" / "wander.yaml"
LEVEL2_ARBITERS = ["inhibitor_wander_heading", "suppressor_avoid_heading"]
LEVEL1_ARBITERS = ["suppressor_turn_heading"]
# the arbiters a dead module's level drives; none for wander, whose line level 2 takes over (through avoid)
MODULES = {"wander": [], "avoid": LEVEL1_ARBITERS,
           "integrate": LEVEL2_ARBITERS, "whenlook": LEVEL2_ARBITERS, "look": LEVEL2_ARBITERS,
           "pathplan": LEVEL2_ARBITERS}
ARBITERS = LEVEL2_ARBITERS + LEVEL1_ARBITERS
ALL_CASES = [f"{name}:{how}" for name in [*MODULES, *ARBITERS] for how in ("rosnode", "sigkill")] + ["simulator:restart"]
# --groups level: a level's process, and the arbiters (alive in the processes below) its death hands back
GROUPS = {"wander_level2": LEVEL2_ARBITERS, "wander_level1": LEVEL1_ARBITERS}
GROUP_CASES = [f"{name}:{how}" for name in GROUPS for how in ("rosnode", "sigkill")] + ["simulator:restart"]


def _wait(condition, timeout: float, step: float = 0.1) -> bool:
    end = time.monotonic() + timeout  # wall clock: waiting for processes, not ROS logic
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(step)
    return False


def run_case(case: str, kill_at: float, after: float, rate: float, seed: int, log_dir: Path,
             groups: str = "none") -> dict:
    """One case on a master of its own; returns its figures."""
    import rosgraph
    import rosnode

    from subsumption.network import load, wire
    from subsumption.ros.launch import launch, launch_env, network_nodes
    from subsumption.ros.master import start_master, stop_processes, tied_to_parent

    target, how = case.split(":")
    master = start_master(env=dict(os.environ, ROS_LOG_DIR=str(log_dir / "ros")))
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri, ROS_LOG_DIR=str(log_dir / "ros")))
    os.environ.update({k: env[k] for k in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME", "ROS_LOG_DIR")})
    subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True)
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Log
    from std_msgs.msg import UInt32

    rospy.init_node("fault_bench", disable_signals=True)
    lock = threading.Lock()
    epoch = [0]  # the simulator restarted: ROS time starts again from 0
    poses: list[tuple[int, float, float, float]] = []
    collisions: dict[int, int] = {}
    holders: list[tuple[int, float, str, str]] = []
    said: list[tuple[int, float, str]] = []

    def on_pose(msg: Odometry) -> None:
        with lock:
            yaw = yaw_of(msg.pose.pose.orientation)
            poses.append((epoch[0], msg.header.stamp.to_sec(), msg.pose.pose.position.x, msg.pose.pose.position.y,
                          yaw))

    def on_collisions(msg: UInt32) -> None:
        with lock:
            collisions[epoch[0]] = max(collisions.get(epoch[0], 0), msg.data)

    def on_status(name: str, msg: DiagnosticStatus) -> None:
        holder = {kv.key: kv.value for kv in msg.values}.get("in_control", "?")
        with lock:
            holders.append((epoch[0], rospy.get_time(), name, holder))

    def on_log(msg: Log) -> None:
        if msg.level >= Log.WARN and msg.name != "/fault_bench":
            with lock:
                said.append((epoch[0], msg.header.stamp.to_sec(), f"{msg.name}: {msg.msg.splitlines()[0][:90]}"))

    rospy.Subscriber("/ground_truth", Odometry, on_pose, queue_size=100)
    rospy.Subscriber("/collisions", UInt32, on_collisions, queue_size=10)
    rospy.Subscriber("/rosout", Log, on_log, queue_size=100)
    for name in ARBITERS:
        rospy.Subscriber(f"/{name}/status", DiagnosticStatus, lambda m, n=name: on_status(n, m), queue_size=50)

    network = load(NETWORK)
    network.module("wander").params["seed"] = seed
    roslaunch_log = log_dir / "roslaunch.log"
    launched = launch(network, 2, env=env, stdout=roslaunch_log.open("w"), stderr=subprocess.STDOUT, groups=groups)
    simulators: list[subprocess.Popen] = []

    def simulator(duration: float) -> subprocess.Popen:
        process = subprocess.Popen(tied_to_parent(
            [sys.executable, str(ROOT / "nodes" / "simulator"), f"_world:={WORLD}", f"_rate:={rate}",
             f"_seed:={seed}", f"_duration:={duration}"]), env=env, start_new_session=True,
            stdout=(log_dir / f"simulator{len(simulators)}.log").open("w"), stderr=subprocess.STDOUT)
        simulators.append(process)
        return process

    result: dict = {"case": case}
    try:
        wanted = {"/" + name for name in network_nodes(wire(network, 2), groups)[0]}
        if not _wait(lambda: wanted <= set(rosnode.get_node_names()), 120, 0.5):
            raise RuntimeError(f"nodes missing: {sorted(wanted - set(rosnode.get_node_names()))}")
        time.sleep(1.0)
        sim = simulator(kill_at + after + 5)
        if not _wait(lambda: rospy.get_time() >= kill_at, 600, 0.05):
            raise RuntimeError("simulated time never reached the kill")
        killed_at = rospy.get_time()
        if target == "simulator":
            sim.send_signal(signal.SIGKILL)
            sim.wait()
            time.sleep(1.0)
            with lock:
                epoch[0] = 1
            killed_at = 0.0
            sim = simulator(after)
        else:
            api = rosgraph.Master("/fault_bench").lookupNode("/" + target)
            pid = xmlrpc.client.ServerProxy(api).getPid("/fault_bench")[2]
            if how == "sigkill":
                os.kill(pid, signal.SIGKILL)
            else:
                subprocess.run(["rosnode", "kill", "/" + target], env=env, capture_output=True, timeout=30)
        sim.wait(timeout=600)
        time.sleep(0.5)
        kill_epoch = epoch[0]
        with lock:
            track = [(t, x, y, yaw) for e, t, x, y, yaw in poses if e == kill_epoch and t >= killed_at]
            late = [(x, y) for t, x, y, _ in track if t >= killed_at + 5.0]
            moved = sum(math.dist(a, b) for a, b in zip(late, late[1:]))
            result["collisions"] = sum(collisions.values())
            result["moved_m"] = round(moved, 2)
            result["moving"] = moved > 1.0
            result["sim_after_s"] = round(track[-1][0] - killed_at, 1) if track else 0.0
            watched = {**MODULES, **GROUPS}.get(target, [])
            result["lower_holds_s"] = _lower_holds(holders, kill_epoch, killed_at, watched) if watched else "n/a"
            result["stopped_s"] = _stopped(track, killed_at) if target in ARBITERS else None
            result["said"] = _said(said, kill_epoch, killed_at, roslaunch_log, target, holders)
    finally:
        stop_processes(simulators)
        launched.stop()
        master.stop()
        rospy.signal_shutdown("case over")
    return result


def _lower_holds(holders, kill_epoch, killed_at, watched) -> float | None:
    """Seconds from the kill until every watched arbiter last said 'lower' (None: never within the run)."""
    latest: dict[str, str] = {}
    for e, t, name, holder in holders:
        if name not in watched:
            continue
        if e < kill_epoch or t < killed_at:
            latest[name] = holder
            continue
        latest[name] = holder
        if all(latest.get(n) == "lower" for n in watched):
            return round(max(0.0, t - killed_at), 2)
    return None


def _stopped(track, killed_at) -> float | None:
    """Seconds from the kill until the robot stood still (< 0.02 m/s and < 0.05 rad/s) and stayed so for 2 s."""
    def still(a, b, slack: float = 1.0) -> bool:
        dt = b[0] - a[0]
        turned = abs(math.remainder(b[3] - a[3], math.tau))
        return dt > 0 and math.dist(a[1:3], b[1:3]) < 0.02 * dt * slack and turned < 0.05 * dt * slack

    for i in range(1, len(track)):
        if still(track[i - 1], track[i]):
            rest = [p for p in track[i:] if p[0] <= track[i][0] + 2.0]
            if len(rest) > 1 and all(still(a, b, 2.0) for a, b in zip(rest, rest[1:])):
                return round(track[i][0] - killed_at, 2)
    return None


def _said(said, kill_epoch, killed_at, roslaunch_log: Path, target: str, holders) -> str:
    parts = []
    log = roslaunch_log.read_text(errors="replace") if roslaunch_log.exists() else ""
    ended = [line for line in log.splitlines() if f"[{target}-" in line and "process has" in line]
    if ended and "died" in ended[0]:
        code = ended[0].split("exit code ")[-1].split(",")[0] if "exit code" in ended[0] else "?"
        parts.append(f"roslaunch: {target} died (exit {code})")
    elif ended:
        parts.append(f"roslaunch: {target} finished cleanly")
    if target in ARBITERS:
        last = max((t for e, t, name, _ in holders if name == target and e == kill_epoch), default=None)
        parts.append(f"~status silent from {last - killed_at:+.1f} s" if last is not None else "~status silent")
    seen = set()
    for e, t, text in said:
        if e == kill_epoch and t >= killed_at and text not in seen and len(seen) < 2:
            seen.add(text)
            parts.append(text)
    return "; ".join(parts) or "nothing"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=None, help="comma-separated NODE:rosnode|sigkill cases (default: all)")
    parser.add_argument("--kill-at", type=float, default=30.0, help="simulated s before the kill")
    parser.add_argument("--after", type=float, default=45.0, help="simulated s watched after the kill")
    parser.add_argument("--rate", type=float, default=3.0, help="simulated s per wall s")
    parser.add_argument("--seed", type=int, default=1, help="wander's seed and the simulator's")
    parser.add_argument("--case", help=argparse.SUPPRESS)  # internal: run one case in this process
    parser.add_argument("--log-dir", type=Path, help="keep each case's logs here (default: a temporary folder)")
    parser.add_argument("--groups", choices=("none", "level"), default="none",
                        help="level: one process per level, and the cases kill a level's process")
    args = parser.parse_args()
    known = GROUP_CASES if args.groups == "level" else ALL_CASES
    if args.cases is None:
        args.cases = ",".join(known)
    if args.case:
        result = run_case(args.case, args.kill_at, args.after, args.rate, args.seed, args.log_dir, args.groups)
        print("RESULT " + json.dumps(result), flush=True)
        return 0
    cases = [c for c in args.cases.split(",") if c]
    unknown = [c for c in cases if c not in known]
    if unknown:
        parser.error(f"--cases: unknown {unknown}; known: {', '.join(known)}")
    started = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    print(f"faults  {started} UTC  wander level 2 on {WORLD.name}, kill at {args.kill_at:g} s, watched "
          f"{args.after:g} s after, rate {args.rate:g}x, seed {args.seed}, groups {args.groups}")
    print(f"{'case':34} {'coll':>4} {'moving':>6} {'moved m':>7} {'lower holds s':>13} {'stopped s':>9}  said")
    results = []
    with tempfile.TemporaryDirectory(prefix="fault_bench_") as temporary:
        base = args.log_dir or Path(temporary)
        for case in cases:
            log_dir = base / case.replace(":", "_")
            log_dir.mkdir(parents=True, exist_ok=True)
            done = subprocess.run([sys.executable, "-m", "bench.faults", "--case", case, "--kill-at", str(args.kill_at),
                                   "--after", str(args.after), "--rate", str(args.rate), "--seed", str(args.seed),
                                   "--log-dir", str(log_dir), "--groups", args.groups], capture_output=True, text=True,
                                  timeout=900, cwd=ROOT)
            line = next((ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")), None)
            if line is None:
                print(f"{case:34} failed: {done.stderr.strip().splitlines()[-1:] or done.returncode}")
                continue
            r = json.loads(line[7:])
            results.append(r)
            fmt = lambda v: "-" if v is None else v if isinstance(v, str) else f"{v:.2f}"  # noqa: E731
            print(f"{case:34} {r['collisions']:>4} {'yes' if r['moving'] else 'no':>6} {r['moved_m']:>7.1f} "
                  f"{fmt(r['lower_holds_s']):>13} {fmt(r['stopped_s']):>9}  {r['said']}", flush=True)
    total = sum(r["collisions"] for r in results)
    print(f"collisions in all cases: {total} (goal 0): {'yes' if total == 0 else 'NO'}")
    arbiter_cases = [r for r in results if r["case"].split(":")[0] in ARBITERS]
    stop_ok = all(r["stopped_s"] is not None or r["moving"] for r in arbiter_cases)
    print(f"a dead arbiter never leaves the robot driving on a stale command: {'yes' if stop_ok else 'NO'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
