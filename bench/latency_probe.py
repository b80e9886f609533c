"""The two ends of one latency measurement, each its own process (rospy allows one node per process, and two
processes keep the sender's and the receiver's GIL out of each other's way).

    python -m bench.latency_probe send TOPIC PLAN_JSON   publishes geometry_msgs/TwistStamped, phase by phase
    python -m bench.latency_probe recv TOPIC             records receive time - header.stamp per phase

Coordination goes through the pipes of bench.arbiter_latency, which is not a ROS node: the receiver prints
``first`` when the path is connected end to end (a relay advertises its output only after its first input),
the bench then writes ``go`` to the sender. The phase of a message is its header.frame_id; ``end`` stops
the receiver, which prints one JSON line. Both ends use tcp_nodelay and deep queues, so what is measured is
the path in between, not the probes' own buffers.
"""
from __future__ import annotations

import json
import select
import sys
import time

import rospy
from geometry_msgs.msg import TwistStamped

QUEUE = 100_000


def send(topic: str, plan: dict) -> None:
    rospy.init_node("latency_sender", anonymous=True, disable_signals=True)
    pub = rospy.Publisher(topic, TwistStamped, queue_size=QUEUE, tcp_nodelay=True)
    msg = TwistStamped()
    msg.twist.linear.x = 0.3
    msg.twist.angular.z = -0.2
    deadline = time.monotonic() + 30
    while pub.get_num_connections() == 0:
        if time.monotonic() > deadline:
            raise SystemExit("sender: nobody subscribed")
        time.sleep(0.01)
    msg.header.frame_id = "warm"
    while not select.select([sys.stdin], [], [], 0.01)[0]:   # warm up at 100 Hz until the bench says go
        msg.header.stamp = rospy.Time.now()
        pub.publish(msg)
    sys.stdin.readline()
    time.sleep(0.2)
    sent: dict[str, int] = {}
    for phase, rate, seconds in plan["phases"]:
        msg.header.frame_id = phase
        count = 0
        start = time.perf_counter()
        end = start + seconds
        period = 1.0 / rate if rate else 0.0
        while True:
            now = time.perf_counter()
            if now >= end:
                break
            if period:
                due = start + count * period
                if now < due:
                    if due - now > 0.0005:
                        time.sleep(due - now - 0.0003)
                    continue
            msg.header.seq = count
            msg.header.stamp = rospy.Time.now()
            pub.publish(msg)
            count += 1
        sent[phase] = count
        time.sleep(plan.get("gap", 0.4))
    msg.header.frame_id = "end"
    for _ in range(50):
        pub.publish(msg)
        time.sleep(0.02)
    print(json.dumps({"sent": sent}), flush=True)


def recv(topic: str) -> None:
    rospy.init_node("latency_receiver", anonymous=True, disable_signals=True)
    latencies: dict[str, list[float]] = {}
    counts: dict[str, int] = {}
    first: dict[str, float] = {}
    last: dict[str, float] = {}
    done = []

    def on_msg(msg: TwistStamped) -> None:
        now = time.time()
        phase = msg.header.frame_id
        if phase == "end":
            done.append(True)
            return
        if phase == "warm" and not counts.get("warm"):
            print("first", flush=True)
        counts[phase] = counts.get(phase, 0) + 1
        first.setdefault(phase, now)
        last[phase] = now
        if phase.startswith("lat"):
            latencies.setdefault(phase, []).append(now - msg.header.stamp.to_sec())

    rospy.Subscriber(topic, TwistStamped, on_msg, queue_size=QUEUE, tcp_nodelay=True, buff_size=1 << 24)
    deadline = time.monotonic() + 180
    while not done and time.monotonic() < deadline:
        time.sleep(0.02)
    print(json.dumps({"counts": counts, "latencies": latencies,
                      "span": {p: last[p] - first[p] for p in first}}), flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "send":
        send(sys.argv[2], json.loads(sys.argv[3]))
    else:
        recv(sys.argv[2])
