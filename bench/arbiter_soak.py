"""Soak: a suppressor and an inhibitor node each under 5,000 messages a second for a minute.

Each arbiter gets its own sender process: the lower line 4,000 msg/s without a break, the upper line 2,000
msg/s every other second (1,000/s on average): 5,000 msg/s in all, and control changing hands every second.
Messages are std_msgs/Float64 numbered by line (lower positive, upper negative), so the receiver knows
which line each output message came from. Figures: every upper message must reach the suppressor's output
(counted by the receiver) and the inhibitor's rule (its ~status: upper passed + dropped = sent, none lost in
the input queue); every lower message must be accounted for on ~status; the arbiter processes' resident memory
(VmRSS) at the start and the end, which must stay flat.

    .venv/bin/python -m bench.arbiter_soak [--duration 60] [--rate 5000]
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

UPPER_SHARE = 0.2  # of the rate: the upper line's average (it speaks every other second, at twice that)
ARBITERS = {"supp": "suppressor", "inh": "inhibitor"}


def sender(name: str, rate: float, duration: float) -> None:
    """Publishes /NAME/upper and /NAME/lower at the paced rates; prints what it sent."""
    import rospy
    from std_msgs.msg import Float64

    rospy.init_node(f"sender_{name}", disable_signals=True)
    upper = rospy.Publisher(f"/{name}/upper", Float64, queue_size=100000, tcp_nodelay=True)
    lower = rospy.Publisher(f"/{name}/lower", Float64, queue_size=100000, tcp_nodelay=True)
    end = time.monotonic() + 30
    while time.monotonic() < end and (upper.get_num_connections() == 0 or lower.get_num_connections() == 0):
        time.sleep(0.05)
    time.sleep(1.0)
    tick = 0.01
    lower_per_tick = rate * (1 - UPPER_SHARE) * tick
    upper_per_tick = 2 * rate * UPPER_SHARE * tick
    sent = {"upper": 0, "lower": 0}
    owed = {"upper": 0.0, "lower": 0.0}
    start = time.monotonic()
    step = 0
    while True:
        now = time.monotonic() - start
        if now >= duration:
            break
        owed["lower"] += lower_per_tick
        if int(now) % 2 == 0:
            owed["upper"] += upper_per_tick
        for _ in range(int(owed["upper"])):
            sent["upper"] += 1
            upper.publish(Float64(-float(sent["upper"])))
        for _ in range(int(owed["lower"])):
            sent["lower"] += 1
            lower.publish(Float64(float(sent["lower"])))
        owed = {k: v - int(v) for k, v in owed.items()}
        step += 1
        delay = start + step * tick - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    sent["seconds"] = time.monotonic() - start
    time.sleep(1.0)
    print("SENT " + json.dumps(sent), flush=True)


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of sending")
    parser.add_argument("--rate", type=float, default=5000.0, help="messages per second into each arbiter")
    parser.add_argument("--sender", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.sender:
        sender(args.sender, args.rate, args.duration)
        return 0

    from subsumption.ros.launch import launch_env
    from subsumption.ros.master import start_master, stop_process

    master = start_master()
    env = launch_env(dict(os.environ, ROS_MASTER_URI=master.uri))
    os.environ.update({k: env[k] for k in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOSTNAME")})
    import rospy
    from diagnostic_msgs.msg import DiagnosticStatus
    from std_msgs.msg import Float64

    nodes: dict[str, subprocess.Popen] = {}
    senders: dict[str, subprocess.Popen] = {}
    try:
        for name, kind in ARBITERS.items():
            nodes[name] = subprocess.Popen(
                [sys.executable, str(ROOT / "nodes" / kind), f"upper:=/{name}/upper", f"lower:=/{name}/lower",
                 f"output:=/{name}/output", f"__name:={name}", "_time_constant:=0.5", "_type:=std_msgs/Float64"],
                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rospy.init_node("soak_receiver", disable_signals=True)
        lock = threading.Lock()
        heard = {name: {"upper": 0, "lower": 0} for name in ARBITERS}
        status: dict[str, dict[str, str]] = {}

        def on_output(name: str, msg: Float64) -> None:
            with lock:
                heard[name]["upper" if msg.data < 0 else "lower"] += 1

        def on_status(name: str, msg: DiagnosticStatus) -> None:
            with lock:
                status[name] = {kv.key: kv.value for kv in msg.values}

        for name in ARBITERS:
            rospy.Subscriber(f"/{name}/output", Float64, lambda m, n=name: on_output(n, m), queue_size=None,
                             tcp_nodelay=True)
            rospy.Subscriber(f"/{name}/status", DiagnosticStatus, lambda m, n=name: on_status(n, m), queue_size=10)
        end = time.monotonic() + 30
        while time.monotonic() < end and len(status) < len(ARBITERS):
            time.sleep(0.1)
        for name in ARBITERS:
            senders[name] = subprocess.Popen([sys.executable, "-m", "bench.arbiter_soak", "--sender", name,
                                              "--rate", str(args.rate),
                                              "--duration", str(args.duration)], env=env, stdout=subprocess.PIPE,
                                             text=True, cwd=ROOT)
        time.sleep(3.0)  # connected and sending: the memory of a node at work
        rss_start = {name: rss_kib(node.pid) for name, node in nodes.items()}
        sent = {}
        for name, process in senders.items():
            out, _ = process.communicate(timeout=args.duration + 120)
            sent[name] = json.loads(next(ln for ln in out.splitlines() if ln.startswith("SENT "))[5:])
        time.sleep(2.5)  # the last messages, and a periodic status after them
        rss_end = {name: rss_kib(node.pid) for name, node in nodes.items()}
        alive = {name: node.poll() is None for name, node in nodes.items()}
    finally:
        for process in [*senders.values(), *nodes.values()]:
            stop_process(process, signal.SIGTERM, timeout=10)
        master.stop()
        rospy.signal_shutdown("soak over")

    print(f"soak  {time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC  {args.rate:g} msg/s into each arbiter "
          f"({1 - UPPER_SHARE:.0%} lower, {UPPER_SHARE:.0%} upper in 1 s bursts) for {args.duration:g} s, T 0.5 s")
    print(f"{'arbiter':11} {'sent/s':>7} {'upper sent':>10} {'upper lost':>10} {'lower sent':>10} "
          f"{'lower unaccounted':>17} {'queue dropped':>13} {'RSS start KiB':>13} {'RSS end KiB':>11} alive")
    ok = True
    for name, kind in ARBITERS.items():
        s, st = sent[name], status[name]
        if kind == "suppressor":
            upper_lost = s["upper"] - heard[name]["upper"]
        else:  # an inhibitor never forwards its upper line: every upper message must have reached the rule
            upper_lost = s["upper"] - (int(st["upper_passed"]) + int(st["upper_dropped"])
                                       - int(st["upper_queue_dropped"]))
        unaccounted = s["lower"] - int(st["lower_passed"]) - int(st["lower_dropped"])
        queue = int(st["upper_queue_dropped"]) + int(st["lower_queue_dropped"])
        rate = (s["upper"] + s["lower"]) / s["seconds"]
        print(f"{kind:11} {rate:7.0f} {s['upper']:>10} {upper_lost:>10} {s['lower']:>10} {unaccounted:>17} "
              f"{queue:>13} {rss_start[name]:>13} {rss_end[name]:>11} {'yes' if alive[name] else 'NO'}")
        ok &= upper_lost == 0 and unaccounted == 0 and alive[name] and rss_end[name] <= rss_start[name] * 1.1 + 2048
    print(f"goals (nothing of the upper line lost, every message accounted for, RSS flat): {'yes' if ok else 'NO'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
